// `contego audit LOG`: verifies the audit log's hash chain and summarises it.
// Exit status 0 when the chain holds, 1 when a line breaks it (named with
// its line number) or the file cannot be read.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>

#include "base/read_file.h"
#include "cli/command.h"
#include "monitor/audit_log.h"

namespace contego::cli {

void register_audit(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand("audit", "Verify an audit log's hash chain and summarise it");
  cmd->add_option("LOG", *path, "the monitor's audit log (JSON lines)")->required();
  cmd->callback([path] {
    if (Status s = require_regular_file(*path); !s.ok()) {
      fmt::print(stderr, "contego audit: {}\n", s.error());
      return set_exit_code(1);
    }
    std::ifstream in(*path);
    if (!in) {
      fmt::print(stderr, "contego audit: cannot read {}\n", *path);
      return set_exit_code(1);
    }
    const monitor::AuditCheck c = monitor::verify_audit(in);
    const monitor::AuditSummary& s = c.summary;
    fmt::print("{}: {} lines, {} decisions", *path, s.lines, s.decisions);
    if (s.last_us > s.first_us) {
      fmt::print(" over {:.3f} s", static_cast<double>(s.last_us - s.first_us) / 1e6);
    }
    fmt::print("\n");
    for (const auto& [d, n] : s.by_decision) fmt::print("  {:<10} {}\n", d, n);
    for (const auto& [t, n] : s.by_task) fmt::print("  task {:<16} {} decisions\n", t, n);
    for (const auto& [e, n] : s.events) fmt::print("  event {:<15} {}\n", e, n);
    if (!c.ok) {
      fmt::print(stderr, "contego audit: {}: {}\n", *path, c.error);
      fmt::print("chain BROKEN at line {}\n", c.bad_line);
      return set_exit_code(1);
    }
    if (s.torn_tail) {
      fmt::print(
          "note: the last record was cut off (the monitor was killed while writing it; its "
          "decision never acted)\n");
    }
    fmt::print("chain intact{}; last line SHA-256 {}\n",
               s.starts_at_genesis ? " from the start of the log" : " (continues an older log)",
               s.last_hash.empty() ? "-" : s.last_hash);
  });
}

}  // namespace contego::cli
