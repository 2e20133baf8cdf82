#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <fmt/core.h>
#include <fstream>
#include <sys/signalfd.h>
#include <thread>

#include "base/unique_fd.h"
#include "cli/audit_args.h"
#include "cli/bus_args.h"
#include "cli/command.h"
#include "cli/guardian.h"
#include "cli/policy_load.h"
#include "cli/setup_args.h"
#include "cli/stop_signals.h"
#include "cli/trusted_setup.h"
#include "cli/user_spec.h"
#include "gate/socket.h"
#include "gate/socket_client.h"
#include "intercept/seccomp/lineage.h"
#include "intercept/seccomp/supervisor.h"

namespace contego::cli {
namespace {

// The monitor connection of `contego run --socket`, made once the program's
// process exists (its supervisor vouches for it in the hello) and before it
// runs: until then there is nothing to forward to, and nothing calls.
class VouchedClient final : public gate::Endpoint {
 public:
  std::unique_ptr<gate::SocketClient> client;
  gate::TransferReply transfer(uint16_t task, const gate::Transfer& t) override {
    return client->transfer(task, t);
  }
  void job_boundary(uint16_t task) override { client->job_boundary(task); }
  void task_exited(uint16_t task) override {
    if (client) client->task_exited(task);
  }
  bool has_bus(uint8_t bus) override { return client->has_bus(bus); }
  uint64_t funcs(uint8_t bus) override { return client->funcs(bus); }
};

// `contego run --socket`'s exit status when its monitor went away.
constexpr int kExitMonitorLost = 3;
// ... when the program executed a file the monitor refused for the task.
constexpr int kExitIdentityRefused = 4;

// Watches the monitor connection of `contego run --socket`; when the monitor
// closes it, raises SIGTERM in this process, which the supervisor takes
// (stop_fd) as the order to end the program.
class MonitorWatch {
 public:
  ~MonitorWatch() { stop(); }
  void start(const gate::SocketClient& client) {
    thread_ = std::thread([this, &client] {
      while (!done_.load()) {
        if (!client.wait_closed(100)) continue;
        // Queued with a mark, so that a signal a user sent is told apart.
        sigval mark{};
        mark.sival_int = kWatchMark;
        sigqueue(getpid(), SIGTERM, mark);
        return;
      }
    });
  }
  void stop() {
    done_.store(true);
    if (thread_.joinable()) thread_.join();
  }
  static constexpr int kWatchMark = 0x6374676d;

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

// What stopped the program: the signal read from the stop signals (SIGTERM
// if none can be read), and whether it was MonitorWatch's.
struct StopCause {
  int signal = SIGTERM;
  bool monitor_lost = false;
};
StopCause stop_cause(const StopSignals& stop) {
  StopCause cause;
  signalfd_siginfo info{};
  if (!stop.fd.valid() ||
      read(stop.fd.get(), &info, sizeof info) != static_cast<ssize_t>(sizeof info)) {
    return cause;
  }
  cause.signal = static_cast<int>(info.ssi_signo);
  cause.monitor_lost = info.ssi_code == SI_QUEUE &&
                       info.ssi_pid == static_cast<uint32_t>(getpid()) &&
                       info.ssi_int == MonitorWatch::kWatchMark;
  return cause;
}

// Under SCHED_FIFO the scheduler wakes a thread away from a CPU that runs
// another of equal priority, so a program and its supervisor that may use
// several CPUs cross between them twice per checked call (docs/performance.md,
// "--rt and one CPU").
void warn_if_rt_spans_cpus(int cpu) {
  cpu_set_t set;
  if (cpu >= 0 || sched_getaffinity(0, sizeof set, &set) != 0 || CPU_COUNT(&set) <= 1) return;
  fmt::print(stderr,
             "contego run: note: --rt without --cpu: the program and its supervisor may run on "
             "{} CPUs, and under SCHED_FIFO every checked call then crosses between two of them "
             "(several times slower); give --cpu N to keep them on one\n",
             CPU_COUNT(&set));
}

}  // namespace

void register_run(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "run", "Run an unmodified program with every bus command checked (seccomp supervisor)");
  struct Args {
    std::string policy, task, socket, audit = "-";
    std::vector<std::string> buses;
    std::vector<int> virtual_buses;
    std::vector<std::string> program;
    std::vector<int> pass_fds;
    uint32_t spin_us = gate::SpinPolicy{}.spin_us;
    bool no_channel = false;
    bool realtime = false;
    int cpu = -1;
    bool allow_degraded = false;
    bool complain = false;
    std::vector<std::string> complain_for;
    std::string user;
    bool same_user = false;
    std::string virtual_state;  // tests: the virtual devices' state, written at exit
    uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
    monitor::AuditOptions audit_options;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--policy", args->policy, "policy file (embedded monitor)");
  cmd->add_option("--task", args->task, "the program's task name in the policy")->required();
  cmd->add_option("--socket", args->socket, "use the monitor daemon at this socket instead");
  cmd->add_option("--audit", args->audit, "audit log of the embedded monitor (- = stderr)");
  add_audit_options(cmd, &args->audit_options);
  add_bus_options(cmd, &args->buses, &args->virtual_buses, &args->virtual_state,
                  " (embedded monitor)");
  cmd->add_option("--spin-us", args->spin_us,
                  "with --socket: busy-wait this long for the monitor's answer before sleeping")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  cmd->add_flag("--no-channel", args->no_channel,
                "with --socket: talk over the socket only, no shared-memory channel");
  add_budget_option(cmd, &args->budget_factor);
  add_complain_options(cmd, &args->complain, &args->complain_for);
  cmd->add_flag("--allow-degraded", args->allow_degraded,
                "embedded monitor: start even if a device does not answer, a sensor cannot be "
                "read, a safe state cannot be applied or a device's bus has no adapter "
                "(audited: degraded-start)");
  cmd->add_flag(
      "--rt", args->realtime,
      "run the program and its supervisor under SCHED_FIFO at the task's policy priority");
  cmd->add_option("--cpu", args->cpu,
                  "run the program (and all it starts) and its supervising thread on this CPU "
                  "only: each checked call then stays on one CPU (with --rt, strongly advised)")
      ->check(CLI::Range(0, CPU_SETSIZE - 1));
  cmd->add_option("--user", args->user,
                  "USER[:GROUP]: run the program under this user (and group): the supervisor "
                  "then runs under another uid than the program (needs root)");
  cmd->add_flag("--same-user", args->same_user,
                "run the program as root although the embedded monitor holds real buses (by "
                "default refused: give --user)");
  cmd->add_option("--pass-fd", args->pass_fds,
                  "a descriptor beyond 0-2 the program inherits (repeatable); every other one "
                  "left open is closed at exec, and none may be an I2C bus node")
      ->allow_extra_args(false)
      ->check(CLI::Range(3, 1 << 20));
  cmd->add_option("program", args->program, "program and its arguments (after --)")->required();
  cmd->callback([args] {
    // SIGINT, SIGTERM and SIGHUP end the program, not the supervisor: they are
    // blocked here (every thread inherits that) and read from a signalfd that
    // the supervisor watches; the program starts with the original mask.
    StopSignals stop;
    // Before anything else (the embedded monitor's start drives the safe
    // state): a bus descriptor the program would inherit refuses the run.
    if (Status inherited = intercept::seccomp::check_inherited(args->pass_fds); !inherited.ok()) {
      fmt::print(stderr, "{}\n", inherited.error());
      return set_exit_code(2);
    }
    intercept::seccomp::Options opt;
    opt.argv = args->program;
    opt.stop_fd = stop.fd.get();
    opt.subreaper = true;
    opt.pass_fds = args->pass_fds;
    opt.child_sigmask = &stop.original;
    opt.cpu = args->cpu;
    if (args->realtime) warn_if_rt_spans_cpus(args->cpu);
    if (!args->user.empty()) {
      auto user = parse_user_spec(args->user);
      if (!user.ok()) {
        fmt::print(stderr, "contego run: {}\n", user.error());
        return set_exit_code(2);
      }
      opt.set_credentials = true;
      opt.uid = user->uid;
      opt.gid = user->gid;
      opt.groups = user->groups;
    }
    if (!args->socket.empty()) {
      std::optional<gate::SpinPolicy> channel;
      if (!args->no_channel) {
        channel = gate::SpinPolicy{};
        channel->spin_us = args->spin_us;
      }
      // The hello names the program (pid, path) this supervisor speaks for;
      // the monitor checks the task's binding against it before it runs.
      VouchedClient endpoint;
      // A monitor that goes away (stopped, crashed) ends the program: every
      // actuation would fail from then on, and a program looping on EIO is
      // worse than one that ends and is restarted by its unit.
      MonitorWatch watch;
      opt.before_start = [&](pid_t child, const std::string& exe) -> std::string {
        gate::wire::Vouch vouch;
        if (!exe.empty() && exe[0] == '/') vouch = {static_cast<uint32_t>(child), exe};
        auto client = gate::SocketClient::connect(args->socket, args->task, channel, vouch);
        if (!client.ok()) return client.error();
        endpoint.client = std::move(*client);
        watch.start(*endpoint.client);
        // Read by run() after this call (the options are this very object).
        opt.task = endpoint.client->task_id();
        if (args->realtime) opt.realtime_priority = endpoint.client->task_priority();
        if (args->realtime && opt.realtime_priority == 0) {
          fmt::print(stderr, "contego run: --rt: task '{}' has no priority in the policy\n",
                     args->task);
        }
        return {};
      };
      // What the program executes later acts for the task only if the
      // monitor checks the task's binding against it again.
      opt.on_exec = [&](pid_t pid) { return endpoint.client->revouch(pid, args->task); };
      auto r = intercept::seccomp::run(opt, endpoint);
      watch.stop();
      if (!r.ok()) {
        fmt::print(stderr, "contego run: {}\n", r.error());
        return set_exit_code(2);
      }
      if (!r->realtime_error.empty()) {
        fmt::print(stderr, "contego run: --rt refused ({}); ran without it\n", r->realtime_error);
      }
      if (!r->identity_refused.empty()) {
        fmt::print(stderr,
                   "contego run: the program executed a file that may not act for task '{}' "
                   "({}): ended it\n",
                   args->task, r->identity_refused);
        return set_exit_code(kExitIdentityRefused);
      }
      const StopCause cause = r->stopped ? stop_cause(stop) : StopCause{};
      if (cause.monitor_lost) {
        fmt::print(stderr,
                   "contego run: the monitor at {} went away (stopped or died): ended the "
                   "program of task '{}', whose actuations could no longer be checked\n",
                   args->socket, args->task);
        return set_exit_code(kExitMonitorLost);
      }
      if (r->stopped) {
        const int sig = cause.signal;
        fmt::print(stderr,
                   "contego run: {}: ended the program; the monitor drives task '{}''s devices "
                   "to their safe state as the connection closes\n",
                   signal_name(sig), args->task);
        return set_exit_code(128 + sig);
      }
      return set_exit_code(r->exit_code);
    }
    if (args->policy.empty()) {
      fmt::print(stderr, "contego run: give --policy (embedded monitor) or --socket\n");
      return set_exit_code(2);
    }
    monitor::SetupOptions so;
    so.policy = args->policy;
    so.task = args->task;  // an unknown task is refused before the safe state is driven
    if (const Status applied = apply_setup_args(*args, so); !applied.ok()) {
      fmt::print(stderr, "contego run: {}\n", applied.error());
      return set_exit_code(2);
    }
    if (so.real_buses.empty() && so.virtual_buses.empty()) so.virtual_buses = {1};
    // If this process dies without a clean end (SIGKILL, a crash), the
    // guardian drives the safe state with a monitor of its own.
    const pid_t supervisor = getpid();
    auto guardian = Guardian::start([&] {
      monitor::SetupOptions lost = so;
      lost.allow_degraded = true;  // drive what can be driven
      lost.safe_state_reason = fmt::format(
          "contego run: the supervisor (pid {}) ended without a clean exit; its guardian "
          "drives the safe state",
          supervisor);
      fmt::print(stderr, "{}\n", lost.safe_state_reason);
      auto t = monitor::setup(lost);
      if (!t.ok()) {
        fmt::print(stderr, "contego run: guardian: {}\n", t.error());
        return 1;
      }
      (*t)->monitor->stop_sampling();
      if (!args->virtual_state.empty()) {
        std::ofstream(args->virtual_state) << monitor::virtual_state(**t);
      }
      return 0;
    });
    if (!guardian.ok()) {
      fmt::print(stderr, "contego run: cannot start the guardian: {}\n", guardian.error());
      return set_exit_code(2);
    }
    auto trusted = monitor::setup(so);
    if (!trusted.ok()) {
      fmt::print(stderr, "contego run: {}\n", trusted.error());
      return set_exit_code(2);
    }
    // After the start checks (their refusals name the bus), before the program runs.
    if (!so.real_buses.empty() && geteuid() == 0 && args->user.empty() && !args->same_user) {
      fmt::print(stderr,
                 "contego run: the embedded monitor holds real buses and runs as root: give "
                 "--user USER[:GROUP] so that the program runs under another uid than its "
                 "supervisor (or --same-user to run it as root anyway)\n");
      return set_exit_code(2);
    }
    for (const auto& w : (*trusted)->warnings) fmt::print(stderr, "contego run: warning: {}\n", w);
    for (const auto& d : (*trusted)->degraded) {
      fmt::print(stderr, "contego run: --allow-degraded: starting although {}\n", d);
    }
    auto it = (*trusted)->tasks.find(args->task);
    if (it == (*trusted)->tasks.end()) {
      fmt::print(stderr, "contego run: policy {} declares no task '{}'\n", args->policy,
                 args->task);
      return set_exit_code(2);
    }
    opt.task = it->second;
    if (args->realtime) opt.realtime_priority = (*trusted)->monitor->task_priority(opt.task);
    if (args->realtime && opt.realtime_priority == 0) {
      fmt::print(stderr, "contego run: --rt: task '{}' has no priority in the policy\n",
                 args->task);
    }
    // The signal is recorded as it is taken, before the program it ends
    // exits (whose exit drives the task's safe state): records in causal order.
    std::atomic<int> stopped_by{0};
    opt.on_stop = [&stop, &stopped_by, audit = &(*trusted)->audit] {
      const int sig = stop.which();
      stopped_by.store(sig);
      audit->event("signal",
                   fmt::format("contego run: {}: ended the supervised program", signal_name(sig)));
    };
    auto r = intercept::seccomp::run(opt, *(*trusted)->monitor);
    if (r.ok() && r->stopped) {
      const int sig = stopped_by.load() != 0 ? stopped_by.load() : stop.which();
      (*trusted)->monitor->drive_safe_state(fmt::format("contego run: {}", signal_name(sig)));
      fmt::print(stderr, "contego run: {}: ended the program; safe state applied\n",
                 signal_name(sig));
      r->exit_code = 128 + sig;
    }
    (*trusted)->monitor->stop_sampling();
    if (!args->virtual_state.empty()) {
      std::ofstream(args->virtual_state) << monitor::virtual_state(**trusted);
    }
    if ((*trusted)->monitor->decision_counts(opt.task).dropped() != 0) {
      // What was dropped or replaced, where the user sees it (details: the audit log).
      fmt::print(stderr, "contego run: task {}: {} (contego audit --explain {})\n", args->task,
                 (*trusted)->monitor->decision_summary(opt.task), args->audit);
    }
    if (!r.ok()) {
      fmt::print(stderr, "contego run: {}\n", r.error());
      return set_exit_code(2);
    }
    if (!r->realtime_error.empty()) {
      fmt::print(stderr, "contego run: --rt refused ({}); ran without it\n", r->realtime_error);
    }
    set_exit_code(r->exit_code);
  });
}

}  // namespace contego::cli
