// Golden-file tests for the policy compiler (after Carbon's file tests).
//
// Every tests/policy/*.policy is compiled; its rendered diagnostics (or, for
// a policy without errors, its diagnostics followed by a one-line verdict)
// must equal tests/policy/<name>.expected byte for byte. Files named fail_*
// must produce at least one error; others must produce none.
//
// Set CONTEGO_UPDATE_GOLDEN=1 (tools/update_golden does) to rewrite the
// .expected files from the current output instead of comparing.
//
// DiagnosticCoverage fails when a diagnostic kind of the registry is produced
// by no golden file, so every diagnostic has at least one test.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <set>
#include <sstream>
#include <string>

#include "cli/sched_closure.h"
#include "policy/compile.h"
#include "policy/diag/diag.h"

namespace contego::policy {
namespace {

namespace fs = std::filesystem;

const fs::path kRoot = CONTEGO_SOURCE_DIR;
const fs::path kDir = kRoot / "tests" / "policy";

// Kinds no golden file can produce, each with the reason.
const std::set<std::string> kExempt = {
    // Produced only when the core's verifier refuses an image the compiler
    // built: a compiler bug by definition, so no policy should reach it. The
    // policy_parser fuzzer aborts if any input does.
    "E0901",
    // A limit of the image format (kMaxDevices ...) needs a policy larger than
    // a golden file should be; compile_test.cc generates one.
    "E0508",
    // Reading the file fails before there is any source to point into; the
    // CTest test check_reports_missing_file covers it through the CLI.
    "E0902",
};

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<fs::path> golden_files() {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(kDir)) {
    if (e.path().extension() == ".policy") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

struct GoldenRun {
  std::string rendered;
  std::set<std::string> ids;
  bool has_error = false;
};

GoldenRun run(const fs::path& file) {
  // The name as seen from the repository root, so output does not depend on
  // where the tree is checked out.
  const std::string name = fs::relative(file, kRoot).generic_string();
  CompileOptions options;
  options.task_model_check = cli::sched_closure;  // as `contego check` does
  const CompileOutput out = compile_source(name, read(file), options);
  GoldenRun r;
  r.rendered = render_text(out.diagnostics);
  for (const auto& d : out.diagnostics) {
    r.ids.insert(d.id);
    for (const auto& n : d.notes) r.ids.insert(n.id);
    r.has_error = r.has_error || d.severity == "error";
  }
  if (!r.has_error) {
    r.rendered += "ok: " + std::to_string(out.image.size()) + " bytes, worst-case cost " +
                  std::to_string(out.worst_case_cost) + "\n";
  }
  return r;
}

TEST(PolicyGolden, EveryFileMatchesItsExpectedOutput) {
  const bool update = std::getenv("CONTEGO_UPDATE_GOLDEN") != nullptr;
  const auto files = golden_files();
  ASSERT_FALSE(files.empty()) << "no golden files in " << kDir;
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const GoldenRun r = run(f);
    const bool expect_fail = f.filename().string().rfind("fail_", 0) == 0;
    EXPECT_EQ(r.has_error, expect_fail)
        << (expect_fail ? "a fail_ file compiled without errors"
                        : "a golden file without fail_ prefix has errors:\n" + r.rendered);
    fs::path expected = f;
    expected.replace_extension(".expected");
    if (update) {
      std::ofstream(expected, std::ios::binary) << r.rendered;
      continue;
    }
    ASSERT_TRUE(fs::exists(expected)) << "missing " << expected << "; run tools/update_golden";
    EXPECT_EQ(r.rendered, read(expected)) << "run tools/update_golden and review the diff";
  }
}

TEST(PolicyGolden, DiagnosticCoverage) {
  std::set<std::string> produced;
  for (const auto& f : golden_files()) {
    const GoldenRun r = run(f);
    produced.insert(r.ids.begin(), r.ids.end());
  }
  for (DiagKind k : all_diag_kinds()) {
    const std::string id = diag_info(k).id;
    if (kExempt.count(id)) {
      EXPECT_EQ(produced.count(id), 0u) << id << " is exempt but a golden file produces it; "
                                        << "remove the exemption";
      continue;
    }
    EXPECT_EQ(produced.count(id), 1u)
        << "diagnostic " << id << " (" << diag_info(k).name
        << ") is produced by no golden file in tests/policy/; add a fail_*.policy for it";
  }
}

}  // namespace
}  // namespace contego::policy
