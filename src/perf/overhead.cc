#include "perf/overhead.h"

#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fmt/core.h>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <thread>

#include "base/clock.h"
#include "bus/virtual_bus.h"
#include "gate/socket.h"
#include "intercept/seccomp/supervisor.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "monitor/server.h"
#include "perf/rig.h"

namespace contego::perf {
namespace {

using namespace detail;

// The bench task's command line (see bench_task.cc): the workload's job
// (commands separated by ','), and PER_JOB commands between sleeps.
std::vector<std::string> task_argv(const Options& o, const Workload& w, uint32_t trials,
                                   const std::string& out, uint32_t period_us,
                                   uint32_t burst_ms = 0) {
  std::string commands;
  for (const auto& c : w.commands()) commands += (commands.empty() ? "" : ",") + hex(c);
  std::vector<std::string> argv = {o.task_exe,
                                   "/dev/i2c-1",
                                   fmt::format("0x{:02x}", w.addr),
                                   commands,
                                   std::to_string(trials),
                                   out,
                                   std::to_string(period_us)};
  if (burst_ms > 0) argv.push_back(std::to_string(burst_ms));
  if (burst_ms == 0 && period_us > 0) argv.push_back(std::to_string(w.commands().size()));
  return argv;
}

std::vector<uint64_t> time_unprotected(bus::Bus& bus, const Workload& w, uint32_t trials) {
  std::vector<uint64_t> ns(trials);
  std::vector<std::vector<uint8_t>> job = w.commands();
  for (uint32_t i = 0; i < trials; ++i) {
    if (w.job_period_us > 0 && i % job.size() == 0) next_job(w.job_period_us);
    std::vector<uint8_t>& buf = job[i % job.size()];
    bus::Msg m{w.addr, 0, static_cast<uint16_t>(buf.size()), buf.data()};
    const uint64_t t0 = monotonic_ns();
    (void)bus.transfer({&m, 1});
    ns[i] = monotonic_ns() - t0;
  }
  return ns;
}

std::vector<uint64_t> time_core(monitor::Monitor& mon, const Workload& w, uint32_t trials,
                                uint64_t* failures) {
  std::vector<uint64_t> ns(trials);
  std::vector<gate::Transfer> job;
  for (const auto& bytes : w.commands()) {
    gate::Transfer t;
    t.bus = 1;
    gate::Message m;
    m.addr = w.addr;
    m.len = static_cast<uint16_t>(bytes.size());
    m.data = bytes;
    t.messages.push_back(m);
    job.push_back(t);
  }
  const uint16_t task = w.task_id;
  for (uint32_t i = 0; i < trials; ++i) {
    if (w.job_period_us > 0 && i % job.size() == 0) {
      next_job(w.job_period_us);
      mon.job_boundary(task);  // what the supervisor reports when the task sleeps
    }
    const gate::Transfer& t = job[i % job.size()];
    const uint64_t t0 = monotonic_ns();
    const gate::TransferReply r = mon.transfer(task, t);
    ns[i] = monotonic_ns() - t0;
    if (r.err != 0) ++*failures;
  }
  return ns;
}

}  // namespace

Stats summarise(std::vector<uint64_t> ns) {
  Stats s;
  s.n = ns.size();
  if (ns.empty()) return s;
  std::sort(ns.begin(), ns.end());
  long double sum = 0;
  for (uint64_t v : ns) sum += static_cast<long double>(v);
  auto rank = [&](double q) {
    // Nearest rank: the smallest value with at least q of the samples at or below it.
    size_t k = static_cast<size_t>(q * static_cast<double>(ns.size()) + 0.999999);
    k = std::clamp<size_t>(k, 1, ns.size());
    return static_cast<double>(ns[k - 1]) / 1000.0;
  };
  s.mean_us = static_cast<double>(sum / static_cast<long double>(ns.size())) / 1000.0;
  s.median_us = rank(0.5);
  s.p99_us = rank(0.99);
  s.p999_us = rank(0.999);
  s.worst_us = static_cast<double>(ns.back()) / 1000.0;
  return s;
}

std::vector<Workload> example_workloads() {
  return {
      // rover.policy, task follower: a GoPiGo2 set-left-speed frame.
      {"rover follower (pass-through)",
       "follower",
       0,
       0x08,
       {0x01, 0x46, 100, 0x00, 0x00},
       {},
       {},
       0},
      // arm.policy, task gripper: LED5 (the gripper servo) pulse 577 (grip_open).
      {"arm gripper (pass-through)", "gripper", 1, 0x40, {0x1A, 0x00, 0x00, 0x41, 0x02}, {}, {}, 0},
  };
}

namespace {

struct PathNames {
  Path path;
  const char* label;
  const char* key;
};

// Both names of every path, in the order of the enum.
constexpr PathNames kPathNames[] = {
    {Path::kUnprotected, "a unprotected", "unprotected"},
    {Path::kPreload, "b preload", "preload"},
    {Path::kPreloadSocket, "b-sock preload", "preload_socket_only"},
    {Path::kSeccompInProcess, "c1 seccomp+checker", "seccomp_in_process"},
    {Path::kSeccompMonitor, "c2 seccomp+monitor", "seccomp_monitor_process"},
    {Path::kSeccompMonitorSocket, "c2-sock seccomp+mon.", "seccomp_monitor_process_socket_only"},
    {Path::kCore, "d in-process core", "in_process_core"},
};

const PathNames* names_of(Path p) {
  for (const PathNames& n : kPathNames) {
    if (n.path == p) return &n;
  }
  return nullptr;
}

}  // namespace

const char* path_label(Path p) {
  const PathNames* n = names_of(p);
  return n != nullptr ? n->label : "?";
}

const char* path_key(Path p) {
  const PathNames* n = names_of(p);
  return n != nullptr ? n->key : "?";
}

bool Row::all_allowed() const {
  uint64_t allowed = 0, total = 0;
  for (const auto& [decision, count] : decisions) {
    total += count;
    if (decision == "allow") allowed += count;
  }
  return total > 0 && allowed == total && failures == 0;
}

const Row* Report::find(const std::string& workload, Path p) const {
  for (const Row& r : rows) {
    if (r.workload == workload && r.path == p) return &r;
  }
  return nullptr;
}

Result<Report> run(const Options& o) {
  if (o.trials == 0) return make_error("--trials must be at least 1");
  if (Status s = check_cpu(o.cpu); !s.ok()) return make_error(s.error());
  if (access(o.task_exe.c_str(), X_OK) != 0) {
    return make_error("cannot execute the bench task program " + o.task_exe);
  }
  TempDir dir;
  if (dir.path.empty()) return make_error(std::string("mkdtemp: ") + strerror(errno));
  const std::vector<Workload> workloads = o.workloads.empty() ? example_workloads() : o.workloads;
  // Each row starts from a fresh monitor (a process of its own for the
  // paths through the separate monitor), so that every row of a workload
  // meets the same decisions: with one monitor per workload, the rows after
  // the first found its rate window spent and the device latched.
  // Every monitor process is forked before this process starts a thread.
  std::map<std::pair<size_t, Path>, std::unique_ptr<MonitorProcess>> processes;
  for (size_t i = 0; i < workloads.size(); ++i) {
    for (Path p : kAllPaths) {
      const bool preload = p == Path::kPreload || p == Path::kPreloadSocket;
      if (!is_remote(p) || (preload && o.preload_lib.empty())) continue;
      auto& proc = processes[{i, p}];
      proc = std::make_unique<MonitorProcess>();
      if (Status s = proc->start(dir.path, fmt::format("monitor-{}-{}", i, static_cast<int>(p)),
                                 workloads[i], o.spin_us);
          !s.ok()) {
        return make_error(s.error());
      }
    }
  }
  const Workload pass = example_workloads()[0];
  MonitorProcess dos_process, dos_rt_process, dos_budget_process;
  if (o.dos) {
    if (Status s = dos_budget_process.start(dir.path, "monitor-dos-budget", pass, o.spin_us, false,
                                            o.dos_period_us);
        !s.ok()) {
      return make_error(s.error());
    }
    if (Status s = dos_process.start(dir.path, "monitor-dos", pass, o.spin_us); !s.ok()) {
      return make_error(s.error());
    }
    if (Status s = dos_rt_process.start(dir.path, "monitor-dos-rt", pass, o.spin_us, true);
        !s.ok()) {
      return make_error(s.error());
    }
  }

  Report report;
  report.checker =
      "per workload: the real core with the named compiled policy, or the pass-through decider "
      "(allow + emit + audit line)";
  report.trials = o.trials;
  report.cpu = o.cpu;
  const std::string out = dir.path + "/samples.bin";
  size_t row_count = 0, row_no = 0;
  for (size_t wi = 0; wi < workloads.size(); ++wi) {
    for (Path p : kAllPaths) row_count += !is_remote(p) || processes.count({wi, p}) ? 1 : 0;
  }
  auto say = [&](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  for (size_t wi = 0; wi < workloads.size(); ++wi) {
    const Workload& w = workloads[wi];
    for (Path p : kAllPaths) {
      const bool remote = is_remote(p);
      const MonitorProcess* proc = nullptr;
      std::unique_ptr<Rig> local;
      const std::string local_audit =
          fmt::format("{}/local-{}-{}-audit.jsonl", dir.path, wi, static_cast<int>(p));
      if (remote) {
        auto found = processes.find({wi, p});
        if (found == processes.end()) continue;  // preload paths without the library
        proc = found->second.get();
      } else {
        auto rig = Rig::make(local_audit, w);
        if (!rig.ok()) return make_error(rig.error());
        local = std::move(*rig);
        local->start();
      }
      Row row;
      row.workload = w.name;
      row.path = p;
      say(fmt::format(
          "[{}/{}] {} / {}: {} commands{}", ++row_no, row_count, w.name, path_label(p), o.trials,
          w.job_period_us > 0
              ? fmt::format(", {} per job every {} us", w.commands().size(), w.job_period_us)
              : ", back to back"));
      const uint64_t row_start = monotonic_ns();
      Result<std::vector<uint64_t>> ns = std::vector<uint64_t>{};
      const auto argv = task_argv(o, w, o.trials, out, w.job_period_us);
      const std::string& audit = remote ? proc->audit() : local_audit;
      const auto before = decisions_in(audit);
      switch (p) {
        case Path::kUnprotected:
          ns = time_unprotected(local->bus, w, o.trials);
          break;
        case Path::kCore:
          ns = time_core(*local->mon, w, o.trials, &row.failures);
          break;
        case Path::kSeccompInProcess:
          ns = run_seccomp(argv, *local->mon, w.task_id, &row.failures, o.cpu);
          break;
        case Path::kSeccompMonitor:
        case Path::kSeccompMonitorSocket: {
          Transport how;
          how.channel = p == Path::kSeccompMonitor;
          how.spin_us = o.spin_us;
          how.cpu = o.cpu;
          ns = run_over_socket(proc->socket(), w, argv, &row.failures, how);
          break;
        }
        case Path::kPreload:
        case Path::kPreloadSocket:
          ns = run_preload(o.preload_lib, o.spin_us, proc->socket(), w, argv, &row.failures,
                           p == Path::kPreload, o.cpu);
          break;
      }
      if (!ns.ok())
        return make_error(fmt::format("{} / {}: {}", w.name, path_label(p), ns.error()));
      if (ns->size() != o.trials) {
        return make_error(fmt::format("{} / {}: {} samples, expected {}", w.name, path_label(p),
                                      ns->size(), o.trials));
      }
      if (p != Path::kUnprotected) row.decisions = minus(decisions_in(audit), before);
      row.stats = summarise(std::move(*ns));
      std::string decided;
      for (const auto& [decision, count] : row.decisions)
        decided += fmt::format(" {} {}", decision, count);
      say(fmt::format("[{}/{}]   done in {:.1f} s: median {:.2f} us, p99 {:.2f} us;{}", row_no,
                      row_count, static_cast<double>(monotonic_ns() - row_start) / 1e9,
                      row.stats.median_us, row.stats.p99_us,
                      decided.empty() ? " (not checked)" : decided));
      report.rows.push_back(row);
    }
  }

  if (o.dos) {
    // The follower keeps its period while the burst task sends back to back,
    // both supervised, both through a separate monitor process, in the
    // variants below.
    const Workload follower = pass;
    Workload burst = follower;
    burst.task = "burst";
    burst.task_id = task_ids().at("burst");
    const auto periodic = task_argv(o, follower, o.trials, out, o.dos_period_us);
    const uint32_t burst_ms =
        static_cast<uint32_t>(uint64_t{o.trials} * o.dos_period_us / 1000u) + 500u;
    const std::string burst_out = dir.path + "/burst.bin";
    struct Variant {
      const char* transport;
      const MonitorProcess* process;
      Transport how;
    };
    const Variant variants[] = {
        {"channel", &dos_process, {true, o.spin_us, false}},
        {"socket", &dos_process, {false, o.spin_us, false}},
        // The follower's program, supervisor and monitor thread under
        // SCHED_FIFO at its policy priority; the burst task has none.
        {"channel, SCHED_FIFO", &dos_rt_process, {true, o.spin_us, true}},
        // Both tasks declare one actuation per period; the monitor holds a
        // task past 4 per period (--budget-factor's default) to the period's end.
        {"channel, budget hold", &dos_budget_process, {true, o.spin_us, false}},
    };
    for (const Variant& v : variants) {
      DosResult dos;
      dos.transport = v.transport;
      dos.period_us = o.dos_period_us;
      const std::string& socket = v.process->socket();
      say(fmt::format("DoS ({}): a follower every {} us, alone then under a burst", v.transport,
                      o.dos_period_us));
      auto quiet = run_over_socket(socket, follower, periodic, nullptr, v.how);
      if (!quiet.ok() && v.how.realtime) {
        dos.skipped = quiet.error();  // no CAP_SYS_NICE here: reported, not fatal
        report.dos.push_back(dos);
        continue;
      }
      if (!quiet.ok()) return make_error("DoS (quiet): " + quiet.error());
      dos.quiet = summarise(std::move(*quiet));
      Transport burst_how = v.how;
      burst_how.realtime = false;
      Result<std::vector<uint64_t>> burst_result = std::vector<uint64_t>{};
      std::thread burster([&] {
        burst_result = run_over_socket(
            socket, burst, task_argv(o, burst, 0, burst_out, 0, burst_ms), nullptr, burst_how);
      });
      usleep(100000);  // the burst is under way
      auto loaded = run_over_socket(socket, follower, periodic, nullptr, v.how);
      burster.join();
      if (!loaded.ok()) return make_error("DoS (under burst): " + loaded.error());
      if (!burst_result.ok()) return make_error("DoS (burst task): " + burst_result.error());
      dos.under_burst = summarise(std::move(*loaded));
      dos.burst_commands = burst_result->empty() ? 0 : burst_result->front();
      report.dos.push_back(dos);
    }
  }
  return report;
}

}  // namespace contego::perf
