// `contego audit LOG...`: verifies the audit log's hash chain and summarises
// it. Several files are one chain, oldest first (rotated files: LOG.3 LOG.2
// LOG.1 LOG): each must continue from the last line of the one before.
// With --explain, every record is first printed in words (one line each).
// With --keys-dir, every signed `checkpoint` record (contego-monitor
// --checkpoint-key) must verify with a trusted minisign key and anchor the
// record it follows. Exit status 0 when the chain holds, 1 when a line breaks
// it (named with its file and line number), a checkpoint does not verify or
// a file cannot be read.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/read_file.h"
#include "bundle/minisign.h"
#include "cli/command.h"
#include "monitor/audit_explain.h"
#include "monitor/audit_log.h"

namespace contego::cli {
namespace {

// Verifies the signed checkpoints of `path` with `keys`: each one's signed
// first line names the SHA-256 its record follows (the record's `prev`) and
// the signature under it verifies. How many did, or the first that did not.
Result<uint64_t> verify_checkpoints(const std::string& path,
                                    const std::vector<bundle::MinisignKey>& keys) {
  std::ifstream in(path);
  std::string line;
  uint64_t n = 0, verified = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.find("\"kind\":\"checkpoint\"") == std::string::npos) continue;
    const auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || j.value("kind", "") != "checkpoint") continue;
    const std::string where = fmt::format("{}: line {}", path, n);
    const std::string detail = j.value("detail", "");
    const size_t cut = detail.find('\n');
    if (cut == std::string::npos) return make_error(where + ": a checkpoint without a signature");
    const std::string signed_text = detail.substr(0, cut);
    const std::string prev = j.value("prev", "");
    if (signed_text.find("last SHA-256 " + (prev.empty() ? std::string("-") : prev)) ==
        std::string::npos) {
      return make_error(where + ": the checkpoint does not name the record it follows (" +
                        signed_text + ")");
    }
    auto v = bundle::verify_minisign(signed_text, detail.substr(cut + 1), where, keys);
    if (!v.ok()) return make_error(v.error());
    ++verified;
  }
  return verified;
}

}  // namespace

void register_audit(CLI::App& app) {
  auto paths = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand("audit", "Verify an audit log's hash chain and summarise it");
  cmd->add_option("LOG", *paths,
                  "the monitor's audit log (JSON lines); several: one chain across rotated "
                  "files, oldest first")
      ->required();
  auto explain = std::make_shared<bool>(false);
  cmd->add_flag("--explain", *explain,
                "first print every record in words, one line each (task, device, command, "
                "decision, rule and reason)");
  auto keys_dir = std::make_shared<std::string>();
  cmd->add_option("--keys-dir", *keys_dir,
                  "verify every signed checkpoint with these trusted minisign public keys "
                  "(*.pub; contego-monitor --checkpoint-key)");
  cmd->callback([paths, explain, keys_dir] {
    if (*explain) {
      for (const std::string& path : *paths) {
        if (Status s = require_regular_file(path); !s.ok()) continue;  // reported below
        std::ifstream in(path);
        std::string line;
        while (std::getline(in, line)) {
          const std::string words = monitor::explain_audit_line(line);
          if (!words.empty()) fmt::print("{}\n", words);
        }
      }
    }
    std::string last_hash;
    uint64_t total_lines = 0, total_decisions = 0;
    bool from_genesis = false;
    std::string first_prev, first_follows;
    for (size_t k = 0; k < paths->size(); ++k) {
      const std::string& path = (*paths)[k];
      if (Status s = require_regular_file(path); !s.ok()) {
        fmt::print(stderr, "contego audit: {}\n", s.error());
        return set_exit_code(1);
      }
      std::ifstream in(path);
      if (!in) {
        fmt::print(stderr, "contego audit: cannot read {}\n", path);
        return set_exit_code(1);
      }
      const monitor::AuditCheck c = monitor::verify_audit(in, k == 0 ? std::string() : last_hash);
      const monitor::AuditSummary& s = c.summary;
      fmt::print("{}: {} lines, {} decisions", path, s.lines, s.decisions);
      if (s.last_us > s.first_us) {
        fmt::print(" over {:.3f} s", static_cast<double>(s.last_us - s.first_us) / 1e6);
      }
      fmt::print("\n");
      for (const auto& [d, n] : s.by_decision) fmt::print("  {:<10} {}\n", d, n);
      for (const auto& [t, n] : s.by_task) fmt::print("  task {:<16} {} decisions\n", t, n);
      for (const auto& [e, n] : s.events) fmt::print("  event {:<15} {}\n", e, n);
      if (!c.ok) {
        fmt::print(stderr, "contego audit: {}: {}\n", path, c.error);
        fmt::print("chain BROKEN at line {}{}\n", c.bad_line,
                   paths->size() > 1 ? " of " + path : std::string());
        return set_exit_code(1);
      }
      if (s.torn_tail) {
        fmt::print(
            "note: the last record was cut off (the monitor was killed while writing it; its "
            "decision never acted)\n");
        if (k + 1 < paths->size()) {
          fmt::print(stderr, "contego audit: {}: a file cut off by a kill is the newest one\n",
                     path);
        }
      }
      if (k == 0) {
        from_genesis = s.starts_at_genesis;
        first_prev = s.first_prev;
        first_follows = s.follows;
      }
      if (!keys_dir->empty()) {
        auto keys = bundle::load_trusted_keys(*keys_dir);
        auto checked = keys.ok() ? verify_checkpoints(path, *keys)
                                 : Result<uint64_t>(make_error(keys.error()));
        if (!checked.ok()) {
          fmt::print(stderr, "contego audit: {}\n", checked.error());
          fmt::print("checkpoint NOT VERIFIED\n");
          return set_exit_code(1);
        }
        fmt::print("  {} signed checkpoint(s) verified\n", *checked);
      }
      if (s.lines > 0) last_hash = s.last_hash;
      total_lines += s.lines;
      total_decisions += s.decisions;
    }
    std::string origin = " from the start of the log";
    if (!from_genesis) {
      origin = fmt::format(" (continues a chain that ended with {}{})",
                           first_prev.empty() ? "-" : first_prev,
                           first_follows.empty() ? "" : ", in " + first_follows);
    }
    if (paths->size() > 1) {
      fmt::print("{} files, {} lines, {} decisions: one chain\n", paths->size(), total_lines,
                 total_decisions);
    }
    fmt::print("chain intact{}; last line SHA-256 {}\n", origin,
               last_hash.empty() ? "-" : last_hash);
  });
}

}  // namespace contego::cli
