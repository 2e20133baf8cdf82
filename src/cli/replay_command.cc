// `contego replay LOG... --policy P`: every decision of the logs re-decided
// by P (learn/replay.h), and a table of what would change. Exit status: 0
// (also with changes, unless --fail-on-change), 1 with --fail-on-change when
// a verdict changed, 2 when the logs or the policy cannot be used.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "cli/command.h"
#include "learn/audit_trace.h"
#include "learn/replay.h"
#include "policy/compile.h"

namespace contego::cli {
namespace {

struct ReplayArgs {
  std::vector<std::string> logs;
  std::string policy;
  bool fail_on_change = false;
};

int run_replay(const ReplayArgs& a) {
  policy::CompileOutput compiled = policy::compile_file(a.policy);
  if (!compiled.ok) {
    for (const policy::Diagnostic& d : compiled.diagnostics) fmt::print(stderr, "{}\n", d.rendered);
    fmt::print(stderr, "contego replay: {} does not compile; nothing replayed\n", a.policy);
    return 2;
  }
  auto trace = learn::read_trace(a.logs);
  if (!trace.ok()) {
    fmt::print(stderr, "contego replay: {}\n", trace.error());
    return 2;
  }
  auto report = learn::replay(*trace, compiled.model, compiled.image);
  if (!report.ok()) {
    fmt::print(stderr, "contego replay: {}: {}\n", a.policy, report.error());
    return 2;
  }
  fmt::print("{}", learn::format_replay(*report, a.policy));
  if (a.fail_on_change && !report->changes.empty()) {
    fmt::print(stderr, "contego replay: {} verdict(s) would change (--fail-on-change)\n",
               report->changes.size());
    return 1;
  }
  return 0;
}

}  // namespace

void register_replay(CLI::App& app) {
  auto args = std::make_shared<ReplayArgs>();
  auto* cmd = app.add_subcommand(
      "replay", "Re-decide every command of audit logs with a policy and print what would change");
  cmd->add_option("LOG", args->logs,
                  "audit logs (several: one chain across rotated files, oldest first)")
      ->required();
  cmd->add_option("--policy", args->policy, "the policy to decide with")->required();
  cmd->add_flag("--fail-on-change", args->fail_on_change,
                "exit 1 when any verdict differs from the recorded one (a CI gate)");
  cmd->callback([args] { set_exit_code(run_replay(*args)); });
}

}  // namespace contego::cli
