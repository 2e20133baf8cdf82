#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <fmt/core.h>
#include <fstream>
#include <mutex>
#include <thread>

#include "cli/audit_args.h"
#include "cli/bus_args.h"
#include "cli/command.h"
#include "cli/setup_args.h"
#include "cli/stop_signals.h"
#include "cli/systemd_notify.h"
#include "cli/trusted_setup.h"
#include "monitor/metrics.h"
#include "monitor/server.h"

namespace contego::cli {
namespace {

// Rewrites the metrics file every interval on its own thread, and once more
// when stopped; a failed write is said on standard error (rate: once per
// interval) and never stops the monitor.
class MetricsWriter {
 public:
  MetricsWriter(monitor::Server& server, std::string path, uint32_t interval_s)
      : server_(server), path_(std::move(path)), interval_(interval_s) {
    if (!path_.empty()) thread_ = std::thread([this] { loop(); });
  }
  ~MetricsWriter() { stop(); }
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
    }
    cv_.notify_all();
    thread_.join();
    write();
  }

 private:
  void loop() {
    std::unique_lock lock(mu_);
    while (!cv_.wait_for(lock, interval_, [this] { return stopping_; })) {
      lock.unlock();
      write();
      lock.lock();
    }
  }
  void write() {
    if (Status s = monitor::write_metrics_file(path_, monitor::metrics_text(server_.status_json()));
        !s.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", s.error());
    }
  }
  monitor::Server& server_;
  std::string path_;
  std::chrono::seconds interval_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace

void register_monitor(CLI::App& app) {
  auto* cmd = app.add_subcommand("monitor", "The trusted-side daemon: sole owner of the buses");
  struct Args {
    std::string policy, image, image_sha256, socket = "/run/contego/monitor.sock", audit = "-";
    std::vector<std::string> buses;
    std::vector<int> virtual_buses;
    std::vector<unsigned> uids;
    uint32_t spin_us = gate::SpinPolicy{}.spin_us;
    bool realtime = false;
    bool allow_degraded = false;
    bool complain = false;
    std::vector<std::string> complain_for;
    std::string virtual_state;  // tests: the virtual devices' state, written at exit
    uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
    monitor::AuditOptions audit_options;
    monitor::ServerLimits limits;
    std::string metrics_file;
    uint32_t metrics_interval_s = 15;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--policy", args->policy, "policy file");
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
                  "/run/contego/metrics/contego.prom)");
  cmd->add_option("--metrics-interval", args->metrics_interval_s,
                  "seconds between two writes of --metrics-file")
      ->check(CLI::Range(1u, 3600u))
      ->capture_default_str();
  cmd->add_option("--client-uid", args->uids, "uid allowed to connect (default: own uid, root)");
  cmd->add_option("--spin-us", args->spin_us,
                  "busy-wait this long for a channel client's next request before sleeping")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  add_budget_option(cmd, &args->budget_factor);
  add_complain_options(cmd, &args->complain, &args->complain_for);
  cmd->add_flag("--allow-degraded", args->allow_degraded,
                "start even if a device does not answer, a sensor cannot be read, a safe state "
                "cannot be applied or a device's bus has no adapter (audited: degraded-start)");
  cmd->add_flag("--rt", args->realtime,
                "serve each connection under SCHED_FIFO at its task's policy priority");
  cmd->callback([args] {
    // SIGINT/SIGTERM/SIGHUP are taken by a waiting thread: the first two
    // stop the server (then the safe state is driven and the exit code is
    // 0); SIGHUP reopens (or rotates) the audit log, is audited, and the
    // monitor keeps serving.
    StopSignals stop;
    const sigset_t& set = stop.set;
    monitor::SetupOptions so;
    so.policy = args->policy;
    so.image = args->image;
    so.image_sha256 = args->image_sha256;
    if (so.policy.empty() && so.image.empty()) {
      fmt::print(stderr, "contego monitor: give --policy FILE or --image FILE\n");
      return set_exit_code(2);
    }
    if (!so.image_sha256.empty() && so.image.empty()) {
      fmt::print(stderr, "contego monitor: --image-sha256 needs --image FILE\n");
      return set_exit_code(2);
    }
    if (const Status applied = apply_setup_args(*args, so); !applied.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", applied.error());
      return set_exit_code(2);
    }
    // Under systemd (stderr is the journal): violations go there too.
    so.audit_options.echo_violations = std::getenv("JOURNAL_STREAM") != nullptr;
    if (so.real_buses.empty() && so.virtual_buses.empty()) {
      fmt::print(stderr, "contego monitor: give at least one --bus or --virtual-bus\n");
      return set_exit_code(2);
    }
    auto trusted = monitor::setup(so);
    if (!trusted.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", trusted.error());
      return set_exit_code(2);
    }
    for (const auto& w : (*trusted)->warnings)
      fmt::print(stderr, "contego monitor: warning: {}\n", w);
    for (const auto& d : (*trusted)->degraded) {
      fmt::print(stderr, "contego monitor: --allow-degraded: starting although {}\n", d);
    }
    std::set<uid_t> uids{getuid(), 0};
    for (unsigned u : args->uids) uids.insert(u);
    gate::SpinPolicy spin;
    spin.spin_us = args->spin_us;
    monitor::Server server(*(*trusted)->monitor, (*trusted)->audit, (*trusted)->tasks, uids, spin,
                           args->realtime, args->limits);
    server.set_bindings((*trusted)->bindings);
    server.set_policy_source((*trusted)->source);
    if (Status s = server.listen(args->socket); !s.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", s.error());
      return set_exit_code(2);
    }
    // The metrics file: written once now, so that a directory the monitor
    // cannot write refuses the start with the reason, then every interval.
    if (!args->metrics_file.empty()) {
      if (Status s = monitor::write_metrics_file(args->metrics_file,
                                                 monitor::metrics_text(server.status_json()));
          !s.ok()) {
        fmt::print(stderr, "contego monitor: {}\n", s.error());
        return set_exit_code(2);
      }
    }
    MetricsWriter metrics(server, args->metrics_file, args->metrics_interval_s);
    const std::string serving = args->image.empty() ? args->policy : args->image;
    fmt::print(stderr, "contego monitor: serving {} on {}\n", serving, args->socket);
    SystemdNotifier systemd;
    systemd.ready(fmt::format("serving {} on {}", serving, args->socket));
    std::atomic<bool> served{false};
    std::string why = "monitor stopping";
    std::thread waiter([&] {
      for (;;) {
        int sig = 0;
        if (sigwait(&set, &sig) != 0 || served.load()) return;
        if (sig == SIGHUP) {
          // logrotate's postrotate: the log is reopened (a file moved away
          // is replaced by a new one that continues the chain; with
          // --audit-max-bytes the log is rotated now).
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
    served.store(true);
    pthread_kill(waiter.native_handle(), SIGTERM);  // wakes it if it still waits
    waiter.join();
    systemd.stopping(why);
    (*trusted)->monitor->drive_safe_state(why);
    (*trusted)->monitor->stop_sampling();
    if (!args->virtual_state.empty()) {
      std::ofstream(args->virtual_state) << monitor::virtual_state(**trusted);
    }
    fmt::print(stderr, "contego monitor: {}; safe state applied\n", why);
  });
}

}  // namespace contego::cli
