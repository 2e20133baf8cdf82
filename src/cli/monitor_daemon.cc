#include "cli/monitor_daemon.h"

#include <grp.h>
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <fmt/core.h>
#include <fstream>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

#include "base/read_file.h"
#include "bundle/bundle.h"
#include "bundle/minisign.h"
#include "cli/audit_args.h"
#include "cli/bus_args.h"
#include "cli/command.h"
#include "cli/journal_sink.h"
#include "cli/policy_reload.h"
#include "cli/setup_args.h"
#include "cli/stop_signals.h"
#include "cli/systemd_notify.h"
#include "cli/trusted_setup.h"
#include "monitor/metrics.h"
#include "monitor/server.h"

namespace contego::cli {
namespace {

// A group by name, or by number whether or not the host names it.
Result<gid_t> parse_group(const std::string& group) {
  if (!group.empty() && group.size() <= 9 &&
      group.find_first_not_of("0123456789") == std::string::npos) {
    return static_cast<gid_t>(std::stoul(group));
  }
  const struct group* gr = getgrnam(group.c_str());
  if (gr == nullptr) return make_error(fmt::format("no group '{}' on this host", group));
  return gr->gr_gid;
}

// Runs `fn` every interval on its own thread until stopped (when stopped,
// once more if `at_stop`). `fn` says what went wrong on standard error
// itself and never stops the monitor.
class Periodic {
 public:
  Periodic(std::function<void()> fn, uint32_t interval_s, bool enabled, bool at_stop)
      : fn_(std::move(fn)), interval_(interval_s), at_stop_(at_stop) {
    if (enabled) thread_ = std::thread([this] { loop(); });
  }
  ~Periodic() { stop(); }
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();
    if (at_stop_) fn_();
  }

 private:
  void loop() {
    std::unique_lock lock(mu_);
    while (!cv_.wait_for(lock, interval_, [this] { return stopping_; })) {
      lock.unlock();
      fn_();
      lock.lock();
    }
  }
  std::function<void()> fn_;
  std::chrono::seconds interval_;
  bool at_stop_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
};

// A signed checkpoint: the chain's anchor (the last record's SHA-256 and the
// count) in a `checkpoint` record, signed with the monitor's minisign key,
// so that a copy off the robot (the journal, a fleet's log store) proves
// what the log held then. The signed text is the detail's first line; the
// rest is the signature file (`minisign -Vm` verifies it too).
bool write_checkpoint(monitor::AuditLog& audit, const bundle::MinisignSecretKey& key) {
  std::string error;
  const bool written =
      audit.anchored_event("checkpoint", [&](const std::string& prev, uint64_t records) {
        const std::string signed_text =
            fmt::format("contego audit checkpoint: {} records, last SHA-256 {}", records,
                        prev.empty() ? "-" : prev);
        auto signature = bundle::sign_minisign(signed_text, key, signed_text);
        if (!signature.ok()) {
          error = signature.error();
          return std::string();
        }
        return signed_text + "\n" + *signature;
      });
  if (!written) {
    fmt::print(stderr, "contego monitor: the signed checkpoint was not written{}{}\n",
               error.empty() ? "" : ": ", error);
  }
  return written;
}

}  // namespace

void add_monitor_options(CLI::App* cmd, MonitorArgs* args, bool daemon) {
  if (daemon) {
    cmd->add_option("--policy", args->policy,
                    "the policy the --bundle-fd bundle was compiled from (`contego monitor "
                    "--policy` passes both; contego-monitor never compiles a policy)");
    cmd->add_option("--bundle-fd", args->bundle_fd, "read the bundle from this descriptor")
        ->group("");
  } else {
    cmd->add_option("--policy", args->policy,
                    "policy file: compiled here, then enforced by contego-monitor");
  }
  cmd->add_option("--bundle", args->bundle,
                  "a policy bundle (`contego check --emit-bundle`): the image and the task "
                  "bindings, all that decides");
  cmd->add_flag("--require-signed", args->require_signed,
                "enforce only a --bundle whose minisign signature verifies with a key of "
                "--keys-dir (no image alone, no policy compiled at start)");
  cmd->add_option("--signature", args->signature,
                  "the bundle's minisign signature (default: BUNDLE.minisig; one that exists is "
                  "always checked)");
  cmd->add_option("--keys-dir", args->keys_dir,
                  "trusted minisign public keys (*.pub) for bundle signatures")
      ->capture_default_str();
  cmd->add_option("--image", args->image,
                  "a verified policy image (`contego check --emit`) to enforce; it must match "
                  "--image-sha256 or the image --policy compiles to");
  cmd->add_option("--image-sha256", args->image_sha256,
                  "the SHA-256 (hex) the --image file must have");
  cmd->add_option("--socket", args->socket, "Unix socket to serve");
  cmd->add_option("--audit", args->audit, "audit log (JSON lines; - = stderr)");
  add_audit_options(cmd, &args->audit_options);
  cmd->add_option("--max-connections-per-uid", args->limits.max_per_uid,
                  "live connections one peer uid may hold; more are refused (0 = no cap)")
      ->capture_default_str();
  cmd->add_option("--hello-timeout-ms", args->limits.hello_timeout_ms,
                  "close a connection that has not said hello within this many ms (0 = never)")
      ->capture_default_str();
  cmd->add_option("--max-connects-per-second", args->limits.connects_per_second,
                  "new connections one peer uid may open per second; more are refused (0 = no "
                  "limit)")
      ->capture_default_str();
  cmd->add_option("--client-events-per-second", args->limits.events_per_second,
                  "client-error events (malformed requests, refused peers...) written per peer uid "
                  "and second; the rest are counted in a `suppressed` summary (0 = no limit)")
      ->capture_default_str();
  add_bus_options(cmd, &args->buses, &args->virtual_buses, &args->virtual_state);
  cmd->add_option("--metrics-file", args->metrics_file,
                  "write counters and gauges in Prometheus's text format to this file, "
                  "atomically, for node_exporter's textfile collector (e.g. "
                  "/run/contego-metrics/contego.prom)");
  cmd->add_option("--metrics-interval", args->metrics_interval_s,
                  "seconds between two writes of --metrics-file")
      ->check(CLI::Range(1u, 3600u))
      ->capture_default_str();
  cmd->add_option("--checkpoint-key", args->checkpoint_key,
                  "an unencrypted minisign secret key (`minisign -G -W`): every "
                  "--checkpoint-interval, and at stop, a `checkpoint` record signed with it "
                  "anchors the log's chain (`contego audit --keys-dir` verifies them)");
  cmd->add_option("--checkpoint-interval", args->checkpoint_interval_s,
                  "seconds between two signed checkpoints")
      ->check(CLI::Range(1u, 86400u))
      ->capture_default_str();
  cmd->add_option("--client-uid", args->uids, "uid allowed to connect (default: own uid, root)");
  cmd->add_option("--status-socket", args->status_socket,
                  "a second, read-only Unix socket: it answers `contego status` and nothing else, "
                  "to root, the monitor's uid and --status-group");
  cmd->add_option("--status-group", args->status_group,
                  "a group (name or gid) whose members may read the status: on --status-socket, "
                  "and on --socket if their uid may connect");
  cmd->add_option("--spin-us", args->spin_us,
                  "busy-wait this long for a channel client's next request before sleeping")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  add_budget_option(cmd, &args->budget_factor)->each([args](const std::string&) {
    args->budget_factor_given = true;
  });
  add_complain_options(cmd, &args->complain, &args->complain_for);
  cmd->add_flag("--allow-degraded", args->allow_degraded,
                "start even if a device does not answer, a sensor cannot be read, a safe state "
                "cannot be applied or a device's bus has no adapter (audited: degraded-start)");
  cmd->add_flag("--rt", args->realtime,
                "serve each connection under SCHED_FIFO at its task's policy priority");
}

std::string monitor_usage_error(const MonitorArgs& args, bool daemon) {
  if (daemon && !args.policy.empty() && args.bundle_fd < 0) {
    return "contego-monitor does not compile policies: run `contego monitor --policy FILE` "
           "(it compiles the policy, then starts contego-monitor with it) or give --bundle FILE "
           "(`contego check --emit-bundle`)";
  }
  if (!args.policy.empty() && !args.bundle.empty()) {
    return "give --policy FILE or --bundle FILE, not both";
  }
  if (args.require_signed && args.bundle.empty()) {
    return "--require-signed enforces a signed --bundle FILE only (`contego check --emit-bundle`, "
           "then `minisign -Sm FILE`)";
  }
  if (!args.signature.empty() && args.bundle.empty()) return "--signature needs --bundle FILE";
  if (args.policy.empty() && args.image.empty() && args.bundle.empty() && args.bundle_fd < 0) {
    return "give --policy FILE, --bundle FILE or --image FILE";
  }
  if (!args.image_sha256.empty() && args.image.empty() && args.bundle.empty()) {
    return "--image-sha256 needs --image FILE or --bundle FILE";
  }
  if (args.buses.empty() && args.virtual_buses.empty() && args.bundle.empty() &&
      args.bundle_fd < 0) {
    return "give at least one --bus or --virtual-bus";  // a bundle may name its buses
  }
  return "";
}

int run_monitor_daemon(const MonitorArgs& args) {
  StopSignals stop;
  const sigset_t& set = stop.set;
  monitor::SetupOptions so;
  so.policy = args.policy;
  so.image = args.image;
  so.image_sha256 = args.image_sha256;
  so.bundle = args.bundle;
  so.bundle_fd = args.bundle_fd;
  so.require_signed = args.require_signed;
  so.signature = args.signature;
  so.keys_dir = args.keys_dir;
  if (const std::string e = monitor_usage_error(args, /*daemon=*/true); !e.empty()) {
    fmt::print(stderr, "contego monitor: {}\n", e);
    return 2;
  }
  if (const Status applied = apply_setup_args(args, so); !applied.ok()) {
    fmt::print(stderr, "contego monitor: {}\n", applied.error());
    return 2;
  }
  // Under systemd (stderr is the journal): violations go there too.
  so.audit_options.echo_violations = std::getenv("JOURNAL_STREAM") != nullptr;
  // The checkpoint key is read before anything starts: a key that does not
  // parse refuses the start.
  std::optional<bundle::MinisignSecretKey> checkpoint_key;
  if (!args.checkpoint_key.empty()) {
    auto text = read_input_file(args.checkpoint_key);
    auto key =
        text.ok() ? bundle::parse_minisign_secret_key(*text, args.checkpoint_key)
                  : Result<bundle::MinisignSecretKey>(make_error("checkpoint key " + text.error()));
    if (!key.ok()) {
      fmt::print(stderr, "contego monitor: --checkpoint-key: {}\n", key.error());
      return 2;
    }
    checkpoint_key = std::move(*key);
  }
  auto loaded = monitor::load_verified(so);
  if (so.bundle_fd >= 0) ::close(so.bundle_fd);  // read whole; no descriptor outlives the load
  if (!loaded.ok()) {
    fmt::print(stderr, "contego monitor: {}\n", loaded.error());
    return 2;
  }
  // Under systemd: violations and events go to the journal as structured
  // entries (priority, MESSAGE_ID, CONTEGO_* fields).
  if (so.audit_options.echo_violations) {
    so.audit_options.journal = make_journal_sink(bundle::image_sha256(loaded->image));
  }
  auto trusted = monitor::setup(so, *loaded);
  if (!trusted.ok()) {
    fmt::print(stderr, "contego monitor: {}\n", trusted.error());
    return 2;
  }
  for (const auto& w : (*trusted)->warnings)
    fmt::print(stderr, "contego monitor: warning: {}\n", w);
  for (const auto& d : (*trusted)->degraded) {
    fmt::print(stderr, "contego monitor: --allow-degraded: starting although {}\n", d);
  }
  std::set<uid_t> uids{getuid(), 0};
  for (unsigned u : args.uids) uids.insert(u);
  gate::SpinPolicy spin;
  spin.spin_us = args.spin_us;
  monitor::Server server(*(*trusted)->monitor, (*trusted)->audit, (*trusted)->tasks, uids, spin,
                         args.realtime, args.limits);
  server.set_bindings((*trusted)->bindings);
  server.set_policy_source((*trusted)->source, (*trusted)->image_sha256);
  // `contego reload`: a new bundle in place, sessions and state kept.
  const bool journal = so.audit_options.journal != nullptr;
  server.set_reloader(make_reloader(so, **trusted, server, [&](const std::string& sha256) {
    if (journal) (*trusted)->audit.set_journal(make_journal_sink(sha256));
  }));
  // `contego run` speaks for the programs it starts (their `exe` before
  // they execute it): the contego installed beside this daemon.
  if (const std::string tool = sibling_path("contego"); !server.trust_supervisor(tool)) {
    fmt::print(stderr,
               "contego monitor: warning: {} not found: `exe` bindings of programs `contego run` "
               "starts are refused\n",
               tool);
  }
  if (Status s = server.listen(args.socket); !s.ok()) {
    fmt::print(stderr, "contego monitor: {}\n", s.error());
    return 2;
  }
  if (!args.status_group.empty()) {
    Result<gid_t> group = parse_group(args.status_group);
    if (!group.ok()) {
      fmt::print(stderr, "contego monitor: --status-group: {}\n", group.error());
      return 2;
    }
    server.set_status_group(*group);
  }
  if (!args.status_socket.empty()) {
    if (Status s = server.listen_status(args.status_socket); !s.ok()) {
      fmt::print(stderr, "contego monitor: --status-socket: {}\n", s.error());
      return 2;
    }
  }
  // The metrics file: written once now, so that a directory the monitor
  // cannot write refuses the start with the reason, then every interval.
  if (!args.metrics_file.empty()) {
    if (Status s = monitor::write_metrics_file(args.metrics_file,
                                               monitor::metrics_text(server.status_json()));
        !s.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", s.error());
      return 2;
    }
  }
  Periodic metrics(
      [&] {
        if (Status s = monitor::write_metrics_file(args.metrics_file,
                                                   monitor::metrics_text(server.status_json()));
            !s.ok()) {
          fmt::print(stderr, "contego monitor: {}\n", s.error());
        }
      },
      args.metrics_interval_s, !args.metrics_file.empty(), /*at_stop=*/true);
  Periodic checkpoints([&] { write_checkpoint((*trusted)->audit, *checkpoint_key); },
                       args.checkpoint_interval_s, checkpoint_key.has_value(), /*at_stop=*/false);
  const std::string serving = !args.image.empty()    ? args.image
                              : !args.bundle.empty() ? args.bundle
                                                     : args.policy;
  fmt::print(stderr, "contego monitor: serving {} on {}\n", serving, args.socket);
  SystemdNotifier systemd;
  systemd.ready(fmt::format("serving {} on {}", serving, args.socket));
  std::atomic<bool> served{false};
  std::string why = "monitor stopping";
  std::thread waiter([&] {
    for (;;) {
      int sig = 0;
      if (sigwait(&set, &sig) != 0 || served.load()) return;
      if (sig == SIGHUP) {
        // logrotate's postrotate: the log is reopened (a file moved away
        // is replaced by a new one that continues the chain; with
        // --audit-max-bytes the log is rotated now). SIGHUP never reloads
        // the policy: that is `contego reload`, which sends the new bundle.
        auto r = (*trusted)->audit.reopen();
        const std::string what = r.ok() ? *r : "cannot reopen the audit log: " + r.error();
        (*trusted)->audit.event("signal", "SIGHUP: still serving; " + what);
        fmt::print(stderr, "contego monitor: SIGHUP: still serving; {}\n", what);
        continue;
      }
      why = fmt::format("monitor stopping ({})", signal_name(sig));
      (*trusted)->audit.event("signal", fmt::format("{}: stopping", signal_name(sig)));
      server.stop();
      return;
    }
  });
  server.serve();
  metrics.stop();
  checkpoints.stop();
  served.store(true);
  pthread_kill(waiter.native_handle(), SIGTERM);  // wakes it if it still waits
  waiter.join();
  systemd.stopping(why);
  (*trusted)->monitor->drive_safe_state(why);
  (*trusted)->monitor->stop_sampling();
  // The last checkpoint covers the stop and its safe state.
  if (checkpoint_key) write_checkpoint((*trusted)->audit, *checkpoint_key);
  if (!args.virtual_state.empty()) {
    std::ofstream(args.virtual_state) << monitor::virtual_state(**trusted);
  }
  fmt::print(stderr, "contego monitor: {}; safe state applied\n", why);
  return 0;
}

}  // namespace contego::cli
