// `contego test POLICY TESTFILE`: policy unit tests run by the trusted core.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fstream>
#include <sstream>

#include "base/read_file.h"
#include "cli/command.h"
#include "policy/compile.h"
#include "policytest/runner.h"
#include "policytest/test_file.h"

namespace contego::cli {

// Exit status: 0 all cases pass, 1 a case fails or the test file does not
// fit the policy, 2 the policy does not compile or the test file does not parse.
int run_policy_tests(const std::string& policy_path, const std::string& test_path) {
  policy::CompileOutput compiled = policy::compile_file(policy_path);
  for (const policy::Diagnostic& d : compiled.diagnostics) {
    if (!compiled.ok || d.severity != "note") fmt::print(stderr, "{}\n", d.rendered);
  }
  if (!compiled.ok) {
    fmt::print(stderr, "{}: does not compile; no test run\n", policy_path);
    return 2;
  }
  Result<std::string> text = read_input_file(test_path);
  if (!text) {
    fmt::print(stderr, "cannot read the test file {}\n", text.error());
    return 2;
  }
  policytest::ParseResult parsed = policytest::parse_test_file(test_path, *text);
  if (!parsed.ok()) {
    for (const policytest::ParseError& e : parsed.errors) fmt::print(stderr, "{}\n", e.rendered);
    return 2;
  }
  Result<policytest::RunReport> report =
      policytest::run_tests(parsed.file, compiled.model, compiled.image, compiled.profiles);
  if (!report) {
    fmt::print(stderr, "{}: {}\n", policy_path, report.error());
    return 2;
  }
  fmt::print("{}", policytest::format_report(*report));
  return report->ok() ? 0 : 1;
}

void register_test(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "test", "Run policy unit tests: compile POLICY, run TESTFILE's cases through the checker");
  auto policy_path = std::make_shared<std::string>();
  auto test_path = std::make_shared<std::string>();
  cmd->add_option("POLICY", *policy_path, "policy source file")->required();
  cmd->add_option("TESTFILE", *test_path, "test file (docs/policy-testing.md)")->required();
  cmd->callback(
      [policy_path, test_path] { set_exit_code(run_policy_tests(*policy_path, *test_path)); });
}

}  // namespace contego::cli
