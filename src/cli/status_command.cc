// `contego status [--socket PATH] [--json]`: what the running monitor
// enforces and how it is doing: the policy and its image's SHA-256, uptime,
// mode, per task its live sessions, current job, budget use and decisions
// by verdict, per device whether it is latched, the audit log's file,
// position and last hash. Root or the monitor's uid. Exit 0, 1 when the
// monitor refused, 2 when it cannot be reached.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "cli/command.h"
#include "gate/operator.h"

namespace contego::cli {
namespace {

void print_human(const nlohmann::json& j) {
  fmt::print("policy:   {}\n", j.value("policy", ""));
  fmt::print("monitor:  pid {}, up {} s, {}; {} decisions, {} holds, {} refused for the audit\n",
             j.value("pid", 0), j.value("uptime_s", 0),
             j.value("complain", false) ? "COMPLAIN MODE (not enforced)" : "enforcing",
             j.value("decisions", 0), j.value("holds", 0), j.value("audit_refusals", 0));
  fmt::print("tasks:\n");
  for (const auto& t : j["tasks"]) {
    const auto& d = t["decisions"];
    std::string budget = "no job yet";
    if (t.contains("budget")) {
      budget = fmt::format("job {}: {} acted, {} dropped", t["budget"].value("job", 0),
                           t["budget"].value("acted", 0), t["budget"].value("dropped", 0));
    }
    const uint64_t staged = d.value("staged", uint64_t{0});
    fmt::print(
        "  {:<16} sessions {}  job {}  ({})  {} allowed{}, {} ignored, {} substituted, "
        "{} refused{}\n",
        t.value("name", ""), t.value("sessions", 0), t.value("job", 0), budget,
        d.value("allowed", 0), staged != 0 ? fmt::format(" ({} staged)", staged) : "",
        d.value("ignored", 0), d.value("substituted", 0), d.value("refused", 0),
        t.value("complain", false) ? "  (complain)" : "");
  }
  fmt::print("devices:\n");
  for (const auto& d : j["devices"]) {
    std::string more;
    if (d.contains("sample_age_ms") && d["sample_age_ms"].is_null()) {
      more += ", NO READING (its signals are unavailable)";
    } else if (d.contains("sample_age_ms")) {
      more += fmt::format(", newest reading {} ms old", d.value("sample_age_ms", 0));
    }
    if (d.contains("safe_state_age_s") && d["safe_state_age_s"].is_null()) {
      more += ", SAFE STATE NOT DRIVEN since the start (--allow-degraded)";
    } else if (d.contains("safe_state_age_s")) {
      more += fmt::format(", safe state driven {} s ago", d.value("safe_state_age_s", 0));
    }
    fmt::print("  {:<16} {}{}\n", d.value("name", ""),
               d.value("latched", false) ? "LATCHED (contego reset clears it)" : "ok", more);
  }
  const auto& a = j["audit"];
  fmt::print("audit:    {} at byte {}, {} records, {} failures, last SHA-256 {}\n",
             a.value("path", ""), a.value("position", 0), a.value("records", 0),
             a.value("failures", 0), a.value("last_hash", ""));
}

}  // namespace

void register_status(CLI::App& app) {
  struct Args {
    std::string socket = "/run/contego/monitor.sock";
    bool json = false;
  };
  // Without --socket: the monitor's socket, else the package's read-only
  // status socket (a member of contego-status cannot enter /run/contego).
  static constexpr const char* kStatusSocket = "/run/contego-status/status.sock";
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "status",
      "Show what the running monitor enforces and how (root, the monitor's uid or its status "
      "group)");
  auto* socket = cmd->add_option("--socket", args->socket,
                                 fmt::format("the monitor's Unix socket or its --status-socket "
                                             "(default: {}, else {})",
                                             args->socket, kStatusSocket));
  cmd->add_flag("--json", args->json, "the monitor's answer as JSON");
  cmd->callback([args, socket] {
    Result<std::string> r = gate::request_status(args->socket);
    if (!r.ok() && socket->count() == 0 && r.error().find("cannot reach") != std::string::npos) {
      if (Result<std::string> other = gate::request_status(kStatusSocket);
          other.ok() || other.error().find("cannot reach") == std::string::npos) {
        r = std::move(other);
      }
    }
    if (!r.ok()) {
      fmt::print(stderr, "contego status: {}\n", r.error());
      const bool unreachable = r.error().find("cannot reach") != std::string::npos;
      return set_exit_code(unreachable ? 2 : 1);
    }
    if (args->json) return fmt::print("{}\n", *r);
    const auto j = nlohmann::json::parse(*r, nullptr, false);
    if (j.is_discarded()) {
      fmt::print(stderr, "contego status: the monitor's answer is not JSON\n");
      return set_exit_code(1);
    }
    print_human(j);
  });
}

}  // namespace contego::cli
