// Tasks under one monitor (issue 40, item 2): N periodic tasks (1, 4, 16,
// 32), each a client of one monitor process as `contego run --socket` is,
// each writing its own PCA9685 channel 3 times per 10 ms job. Per task: the
// time of a checked write (p50, p99, worst) beside the same task's write to
// a plain in-process adapter (a virtual bus without a monitor) in the same
// run; in total: decisions per second at that rate, and back to back (every
// task writing without a pause) to find where the monitor saturates.
//
// The monitor is the real one (core, policy, hash-chained audit file,
// Server with its per-connection threads), in its own process; the tasks
// are threads of this process, each with its own connection.
//
// Usage: tasks_scale DIR [JOBS (default 300)] [TASK COUNTS (default 1,4,16,32)]
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fmt/core.h>
#include <map>
#include <memory>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <vector>

#include "bus/virtual_bus.h"
#include "gate/socket.h"
#include "gate/socket_client.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "monitor/server.h"
#include "policy/compile.h"

namespace contego {
namespace {

constexpr uint32_t kPeriodUs = 10000;
constexpr uint32_t kPerJob = 3;
constexpr uint32_t kBackToBackMs = 1000;

uint64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<uint64_t>(t.tv_sec) * 1'000'000'000u + static_cast<uint64_t>(t.tv_nsec);
}

// N tasks, task i owning channel i % 16 of PCA9685 number i / 16: its
// access, a limit of 3 per job on its channel; one range invariant per chip.
std::string policy_text(uint32_t tasks) {
  std::string p;
  const uint32_t chips = (tasks + 15) / 16;
  for (uint32_t d = 0; d < chips; ++d) {
    p += fmt::format("device pwm{} : pca9685 at i2c-1 0x{:02x}\n", d, 0x40 + d);
    p += fmt::format("invariant RANGE{} on pwm{}.led: require off <= 600 else ignore\n", d, d);
  }
  for (uint32_t i = 0; i < tasks; ++i) {
    p += fmt::format(
        "task t{} {{ period 10ms; deadline 10ms; wcet 1ms; priority 1; actuations 3 }}\n", i);
    p += fmt::format("allow t{} -> pwm{}\n", i, i / 16);
    p += fmt::format("limit t{} -> pwm{}.led({}) 3 per job else ignore\n", i, i / 16, i % 16);
  }
  return p;
}

// One command: the channel's LEDn_OFF_H alone (the group's last register:
// it commits with the shadow's other bytes), off = 0x100 or 0x200.
gate::Transfer command(uint32_t task, uint32_t k) {
  gate::Transfer t;
  t.bus = 1;
  const auto reg = static_cast<uint8_t>(0x09 + 4 * (task % 16));
  t.messages.push_back(
      {static_cast<uint16_t>(0x40 + task / 16), 0, 2, {reg, static_cast<uint8_t>(1 + (k & 1))}});
  return t;
}

struct Sorted {
  std::vector<uint64_t> ns;
  uint64_t at(double q) const {
    return ns.empty() ? 0
                      : ns[std::min(ns.size() - 1,
                                    static_cast<size_t>(q * static_cast<double>(ns.size())))];
  }
};

struct TaskResult {
  Sorted checked, plain;
  uint64_t failures = 0;
  uint64_t back_to_back = 0;  // checked writes in kBackToBackMs
};

pid_t start_monitor(const std::string& dir, const policy::CompileOutput& out, uint32_t tasks,
                    const std::string& socket) {
  fflush(nullptr);
  const pid_t pid = fork();
  if (pid != 0) return pid;
  bus::VirtualBus bus;
  for (uint32_t d = 0; d < (tasks + 15) / 16; ++d) {
    bus.attach(std::make_shared<bus::Pca9685>(static_cast<uint16_t>(0x40 + d)));
  }
  monitor::CoreDecider decider;
  if (decider.checker().load(out.image.data(), static_cast<uint32_t>(out.image.size())).status !=
      core::LoadStatus::kOk) {
    _exit(1);
  }
  monitor::AuditLog audit;
  if (!audit.open(fmt::format("{}/audit-{}.jsonl", dir, tasks)).ok()) _exit(1);
  monitor::Monitor mon(decider, audit);
  mon.add_bus(1, &bus);
  mon.set_names(monitor::name_table(out.model));
  mon.set_drop_report(nullptr);
  std::map<std::string, uint16_t> ids;
  for (uint32_t i = 0; i < tasks; ++i) ids[fmt::format("t{}", i)] = static_cast<uint16_t>(i);
  monitor::ServerLimits limits;
  limits.max_per_uid = 4 * tasks + 16;
  limits.connects_per_second = 0;
  monitor::Server server(mon, audit, ids, {getuid()}, gate::SpinPolicy{}, false, limits);
  if (!server.listen(socket).ok()) _exit(1);
  server.serve();
  _exit(0);
}

void run_task(const std::string& socket, uint32_t task, uint32_t jobs, uint64_t start_ns,
              std::atomic<bool>& b2b_go, std::atomic<bool>& b2b_stop, TaskResult* r) {
  auto c = gate::SocketClient::connect(socket, fmt::format("t{}", task));
  if (!c.ok()) {
    fmt::print(stderr, "tasks_scale: t{}: {}\n", task, c.error());
    r->failures = jobs * kPerJob;
    return;
  }
  bus::VirtualBus plain;  // the same write to an adapter nobody checks
  plain.attach(std::make_shared<bus::Pca9685>(static_cast<uint16_t>(0x40 + task / 16)));
  const uint16_t id = (*c)->task_id();
  // Each task's jobs in its own slot of the period, as tasks with offsets.
  const uint64_t slot = kPeriodUs * 1000ull * task / 32;
  for (uint32_t j = 0; j < jobs; ++j) {
    const uint64_t release = start_ns + slot + uint64_t{j} * kPeriodUs * 1000;
    const uint64_t now = now_ns();
    if (release > now) std::this_thread::sleep_for(std::chrono::nanoseconds(release - now));
    for (uint32_t k = 0; k < kPerJob; ++k) {
      gate::Transfer t = command(task, j * kPerJob + k);
      uint64_t t0 = now_ns();
      if ((*c)->transfer(id, t).err != 0) ++r->failures;
      r->checked.ns.push_back(now_ns() - t0);
      bus::Msg m{t.messages[0].addr, 0, 2, t.messages[0].data.data()};
      t0 = now_ns();
      (void)plain.transfer({&m, 1});
      r->plain.ns.push_back(now_ns() - t0);
    }
    (*c)->job_boundary(id);
  }
  while (!b2b_go.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
  for (uint32_t k = 0; !b2b_stop.load(); ++k) {
    // One command per job: the task's limit never drops it, the monitor decides each.
    if ((*c)->transfer(id, command(task, k)).err == 0) ++r->back_to_back;
    (*c)->job_boundary(id);
  }
}

int run(int argc, char** argv) {
  if (argc < 2) {
    fmt::print(stderr, "usage: tasks_scale DIR [JOBS] [TASK COUNTS, e.g. 1,4,16,32]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const uint32_t jobs = argc > 2 ? static_cast<uint32_t>(std::atoi(argv[2])) : 300;
  std::vector<uint32_t> counts{1, 4, 16, 32};
  if (argc > 3) {
    counts.clear();
    for (const char* p = argv[3]; *p != 0;) {
      char* end = nullptr;
      counts.push_back(static_cast<uint32_t>(std::strtoul(p, &end, 10)));
      p = *end == ',' ? end + 1 : end;
      if (counts.back() == 0 || counts.back() > 32) return fmt::print(stderr, "1..32 tasks\n"), 2;
    }
  }
  fmt::print(
      "{} jobs of {} writes every {} ms per task; times in µs: the task's checked write "
      "(monitor process, socket client) and, in the same run, its write to a plain "
      "in-process adapter\n\n",
      jobs, kPerJob, kPeriodUs / 1000);
  fmt::print("{:>5} {:>9} | {:>7} {:>7} {:>7} | {:>9} {:>9} {:>7} | {:>7} {:>7} | {:>12}\n",
             "tasks", "offered/s", "p50", "p99", "worst", "p99 task*", "p99 worst", "added",
             "plain50", "plain99", "back-to-back");
  bool failed = false;
  for (uint32_t n : counts) {
    const policy::CompileOutput out = policy::compile_source("scale.policy", policy_text(n));
    if (!out.ok) {
      fmt::print(stderr, "tasks_scale: the generated policy does not compile\n");
      return 1;
    }
    const std::string socket = fmt::format("{}/m{}.sock", dir, n);
    const pid_t monitor = start_monitor(dir, out, n, socket);
    bool up = false;
    for (int i = 0; i < 500 && !up; ++i) {
      up = gate::connect_to_monitor(socket).ok();
      if (!up) usleep(10000);
    }
    if (!up) {
      fmt::print(stderr, "tasks_scale: the monitor did not come up\n");
      kill(monitor, SIGKILL);
      waitpid(monitor, nullptr, 0);
      return 1;
    }
    std::vector<TaskResult> results(n);
    std::atomic<bool> go{false}, stop{false};
    const uint64_t start = now_ns() + 50'000'000;
    std::vector<std::thread> threads;
    for (uint32_t i = 0; i < n; ++i) {
      threads.emplace_back(run_task, socket, i, jobs, start, std::ref(go), std::ref(stop),
                           &results[i]);
    }
    std::this_thread::sleep_until(std::chrono::steady_clock::now() +
                                  std::chrono::microseconds(50'000 + uint64_t{jobs} * kPeriodUs));
    // Wait until every task finished its jobs, then the back-to-back phase.
    bool all_done = false;
    while (!all_done) {
      all_done = true;
      for (const auto& r : results) all_done &= r.checked.ns.size() >= jobs * kPerJob;
      if (!all_done) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    go = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(kBackToBackMs));
    stop = true;
    for (auto& t : threads) t.join();
    kill(monitor, SIGTERM);
    waitpid(monitor, nullptr, 0);

    Sorted all, plain;
    std::vector<uint64_t> task_p99;
    uint64_t failures = 0, b2b = 0;
    for (auto& r : results) {
      std::sort(r.checked.ns.begin(), r.checked.ns.end());
      std::sort(r.plain.ns.begin(), r.plain.ns.end());
      task_p99.push_back(r.checked.at(0.99));
      all.ns.insert(all.ns.end(), r.checked.ns.begin(), r.checked.ns.end());
      plain.ns.insert(plain.ns.end(), r.plain.ns.begin(), r.plain.ns.end());
      failures += r.failures;
      b2b += r.back_to_back;
    }
    std::sort(all.ns.begin(), all.ns.end());
    std::sort(plain.ns.begin(), plain.ns.end());
    std::sort(task_p99.begin(), task_p99.end());
    const auto us = [](uint64_t ns) {
      return fmt::format("{:.1f}", static_cast<double>(ns) / 1e3);
    };
    fmt::print("{:>5} {:>9} | {:>7} {:>7} {:>7} | {:>9} {:>9} {:>7} | {:>7} {:>7} | {:>10}/s\n", n,
               n * kPerJob * (1'000'000 / kPeriodUs), us(all.at(0.5)), us(all.at(0.99)),
               us(all.ns.empty() ? 0 : all.ns.back()), us(task_p99[task_p99.size() / 2]),
               us(task_p99.back()), us(all.at(0.99) - std::min(all.at(0.99), plain.at(0.99))),
               us(plain.at(0.5)), us(plain.at(0.99)), b2b * 1000 / kBackToBackMs);
    if (failures != 0) {
      fmt::print("  {} writes failed\n", failures);
      failed = true;
    }
  }
  fmt::print(
      "\np99 task*: the median task's p99; p99 worst: the worst task's p99; added: p99 of "
      "all checked writes minus p99 of all plain ones; back-to-back: checked writes per "
      "second of all tasks together, each writing without a pause for {} ms\n",
      kBackToBackMs);
  fmt::print("{}\n", failed ? "FAILED" : "ok");
  return failed ? 1 : 0;
}

}  // namespace
}  // namespace contego

int main(int argc, char** argv) { return contego::run(argc, argv); }
