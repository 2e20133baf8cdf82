// `contego policy generate LOG... --from OBSERVE.policy -o OUT.policy`: a
// policy (and a test file) fitted to the traffic of audit logs recorded
// under an observe policy (learn/generate.h). Exit status: 0 written, 1 the
// generated policy does not compile (printed with its diagnostics), 2 the
// logs or the observe policy cannot be used.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>

#include "cli/command.h"
#include "learn/audit_trace.h"
#include "learn/generate.h"
#include "policy/compile.h"

namespace contego::cli {
namespace {

struct GenerateArgs {
  std::vector<std::string> logs;
  std::string from, output, tests;
  uint32_t margin = 25;
};

bool write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.close();
  if (!out) fmt::print(stderr, "contego policy generate: cannot write {}\n", path);
  return static_cast<bool>(out);
}

int run_generate(const GenerateArgs& a) {
  auto trace = learn::read_trace(a.logs);
  if (!trace.ok()) {
    fmt::print(stderr, "contego policy generate: {}\n", trace.error());
    return 2;
  }
  learn::GenerateOptions o;
  o.observe_policy = a.from;
  o.logs = a.logs;
  o.margin_percent = a.margin;
  o.test_file_name = a.tests.empty() ? "TESTFILE" : a.tests;
  auto g = learn::generate_policy(*trace, o);
  if (!g.ok()) {
    fmt::print(stderr, "contego policy generate: {}\n", g.error());
    return 2;
  }
  if (a.output.empty()) {
    fmt::print("{}", g->policy);
  } else if (!write_text(a.output, g->policy)) {
    return 2;
  }
  if (!a.tests.empty() && !write_text(a.tests, g->tests)) return 2;
  // What the generated rules cannot do, said where the user sees it.
  for (const std::string& f : g->findings) fmt::print(stderr, "contego policy generate: {}\n", f);
  const policy::CompileOutput check =
      policy::compile_source(a.output.empty() ? "(generated)" : a.output, g->policy);
  if (!check.ok) {
    for (const auto& d : check.diagnostics) fmt::print(stderr, "{}\n", d.rendered);
    fmt::print(stderr, "contego policy generate: the generated policy does not compile\n");
    return 1;
  }
  if (!a.output.empty()) {
    fmt::print(stderr, "contego policy generate: wrote {}{}; next: contego check --strict {}\n",
               a.output, a.tests.empty() ? "" : " and " + a.tests, a.output);
  }
  return 0;
}

}  // namespace

void register_policy(CLI::App& app) {
  auto* policy = app.add_subcommand("policy", "Policy tools: generate a policy from audit logs");
  policy->require_subcommand(1);
  auto args = std::make_shared<GenerateArgs>();
  auto* cmd = policy->add_subcommand(
      "generate",
      "Write a policy fitted to audit logs recorded under an observe policy (run with "
      "--complain)");
  cmd->add_option("LOG", args->logs,
                  "audit logs (several: one chain across rotated files, oldest first)")
      ->required();
  cmd->add_option("--from", args->from,
                  "the observe policy the logs were recorded under (its devices, constants, "
                  "signals and task bindings are kept)")
      ->required();
  cmd->add_option("-o,--output", args->output, "write the policy here (default: standard output)");
  cmd->add_option("--tests", args->tests,
                  "also write a `contego test` file of cases from the logs");
  cmd->add_option("--margin", args->margin,
                  "percent added to the observed per-job maxima and value ranges")
      ->check(CLI::Range(0u, 1000u))
      ->capture_default_str();
  cmd->callback([args] { set_exit_code(run_generate(*args)); });
}

}  // namespace contego::cli
