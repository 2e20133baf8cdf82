// `contego demo`: the main job until the simulation demo replaces it. Checks
// every example policy (compile + the core's verifier) and runs the rover
// policy's unit tests through the trusted core, printing the verdict table.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "cli/command.h"
#include "policy/compile.h"

namespace contego::cli {

int run_policy_tests(const std::string &policy_path, const std::string &test_path);

namespace {

int run_demo(const std::string &dir) {
  std::vector<std::filesystem::path> policies;
  std::error_code ec;
  for (const auto &entry : std::filesystem::directory_iterator(dir, ec)) {
    if (entry.path().extension() == ".policy") policies.push_back(entry.path());
  }
  if (ec || policies.empty()) {
    fmt::print(stderr,
               "{}: no example policies found (run from the repository root or pass "
               "--policies DIR)\n",
               dir);
    return 2;
  }
  std::sort(policies.begin(), policies.end());
  fmt::print("== checking {} example policies ==\n", policies.size());
  int status = 0;
  for (const auto &path : policies) {
    policy::CompileOutput out = policy::compile_file(path.string());
    size_t warnings = 0;
    for (const policy::Diagnostic &d : out.diagnostics) {
      if (d.severity == "warning") ++warnings;
      if (d.severity != "note") fmt::print("{}\n", d.rendered);
    }
    if (!out.ok) {
      fmt::print("{:<28} FAILED to compile\n", path.string());
      status = 1;
      continue;
    }
    fmt::print(
        "{:<28} ok: {} devices, {} tasks, {} invariants, {} rate rules, "
        "image {} bytes, "
        "worst case {} bytecode instructions per check{}\n",
        path.string(), out.model.devices.size(), out.model.tasks.size(),
        out.model.invariants.size(), out.model.rates.size(), out.image.size(), out.worst_case_cost,
        warnings ? fmt::format(", {} warning(s)", warnings) : std::string());
  }
  const std::filesystem::path rover = std::filesystem::path(dir) / "rover";
  fmt::print("\n== contego test {0}.policy {0}.test ==\n", rover.string());
  const int tests = run_policy_tests(rover.string() + ".policy", rover.string() + ".test");
  return status != 0 ? status : tests;
}

}  // namespace

void register_demo(CLI::App &app) {
  auto *cmd = app.add_subcommand(
      "demo", "Check every example policy and run the rover policy's unit tests");
  auto dir = std::make_shared<std::string>("policies");
  cmd->add_option("--policies", *dir, "directory of example policies")->capture_default_str();
  cmd->callback([dir] { set_exit_code(run_demo(*dir)); });
}

}  // namespace contego::cli
