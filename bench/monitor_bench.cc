// The in-process enclave path (`contego bench`'s path d) piece by piece:
// one checked transfer through monitor::Monitor with the compiled example
// policy (arm.policy's gripper write, the bench's arm row), with and without
// its audit record, and the audit record alone. ns per call; run it under
// callgrind for instructions. Release preset for real figures:
//   build/release/bench/monitor_bench
#include <benchmark/benchmark.h>
#include <cstdlib>
#include <fstream>
#include <string>

#include "base/read_file.h"
#include "monitor/audit_log.h"
#include "monitor/sha256.h"
#include "perf/rig.h"
#include "policy/compile.h"

namespace contego {
namespace {

std::string policy_path(const char* file) {
  const char* dir = std::getenv("CONTEGO_POLICY_DIR");
  return std::string(dir != nullptr ? dir : CONTEGO_SOURCE_POLICIES) + "/" + file;
}

// Task `task` of the compiled example policy `file`, writing to `addr`
// (no image: the policy did not compile).
perf::Workload policy_task(const char* file, const char* task, uint8_t addr) {
  perf::Workload w;
  const std::string path = policy_path(file);
  Result<std::string> text = read_input_file(path);
  if (!text) return w;
  const policy::CompileOutput out = policy::compile_source(path, *text);
  if (!out.ok) return w;
  w.name = std::string(file) + " " + task;
  w.task = task;
  w.addr = addr;
  w.image = out.image;
  for (size_t i = 0; i < out.model.tasks.size(); ++i) {
    if (out.model.tasks[i].name == task) w.task_id = static_cast<uint16_t>(i);
  }
  return w;
}

// arm.policy's gripper: the 6DOF arm library's set_pwm(0, 0, 420), one
// register per write (contego bench's arm row): three staged, the fourth
// completing the pulse SERVO_WINDOW checks. One pulse per job, as the
// policy allows.
perf::Workload arm_gripper() {
  perf::Workload w = policy_task("arm.policy", "gripper", 0x40);
  w.job = {{0x06, 0x00}, {0x07, 0x00}, {0x08, 420 & 0xFF}, {0x09, 420 >> 8}};
  return w;
}

// Every decision in the log at `path` was `allow` (else the bench timed
// another path than it says): an error message, or empty.
std::string all_allowed(const std::string& path) {
  std::ifstream in(path);
  const monitor::AuditCheck check = monitor::verify_audit(in);
  if (!check.ok) return "the audit log does not verify: " + check.error;
  const auto allowed = check.summary.by_decision.find("allow");
  const uint64_t n = allowed == check.summary.by_decision.end() ? 0 : allowed->second;
  if (n != check.summary.decisions) {
    return std::to_string(check.summary.decisions - n) + " of " +
           std::to_string(check.summary.decisions) + " decisions were not allow";
  }
  return "";
}

gate::Transfer one_write(const perf::Workload& w) {
  gate::Transfer t;
  t.bus = 1;
  gate::Message m;
  m.addr = w.addr;
  m.len = static_cast<uint16_t>(w.bytes.size());
  m.data = w.bytes;
  t.messages.push_back(m);
  return t;
}

// One transfer per write of the workload's job, in order.
std::vector<gate::Transfer> job_transfers(perf::Workload w) {
  std::vector<gate::Transfer> job;
  for (const std::vector<uint8_t>& bytes : w.commands()) {
    w.bytes = bytes;
    job.push_back(one_write(w));
  }
  return job;
}

// Monitor::transfer of the gripper's writes, each job's on a manual clock
// that moves one period per job (outside the timing); `audited`: to a file
// in /tmp (the bench's rig), else no log at all.
void BM_MonitorTransfer(benchmark::State& state, bool audited) {
  const perf::Workload w = arm_gripper();
  if (w.image.empty()) {
    state.SkipWithError("arm.policy did not compile (set CONTEGO_POLICY_DIR)");
    return;
  }
  constexpr uint64_t kPeriodUs = 1000000;  // arm.policy's gripper
  ManualClock clock(kPeriodUs);
  perf::detail::TempDir dir;
  auto rig = perf::detail::Rig::make(audited ? dir.path + "/audit.jsonl" : "", w, clock);
  if (!rig.ok()) {
    state.SkipWithError(rig.error().c_str());
    return;
  }
  const std::vector<gate::Transfer> job = job_transfers(w);
  uint64_t failures = 0;
  size_t n = 0;
  for (auto _ : state) {
    if (n % job.size() == 0) {
      state.PauseTiming();
      clock.set_us(clock.now_us() + kPeriodUs);
      state.ResumeTiming();
    }
    const gate::TransferReply r = (*rig)->mon->transfer(w.task_id, job[n++ % job.size()]);
    failures += r.err != 0;
  }
  if (failures != 0) state.SkipWithError("a transfer failed");
  if (audited) {
    if (const std::string why = all_allowed(dir.path + "/audit.jsonl"); !why.empty())
      state.SkipWithError(why.c_str());
  }
}
BENCHMARK_CAPTURE(BM_MonitorTransfer, audited, true);
BENCHMARK_CAPTURE(BM_MonitorTransfer, unaudited, false);

// rover.policy's follower, the bench's rover row: three allowed commands a
// job (its rate limit), on a manual clock that moves one period per job;
// the sensors are sampled at each job's start, outside the timing.
void BM_MonitorTransferRover(benchmark::State& state) {
  perf::Workload w = policy_task("rover.policy", "follower", 0x08);
  if (w.image.empty()) {
    state.SkipWithError("rover.policy did not compile (set CONTEGO_POLICY_DIR)");
    return;
  }
  constexpr uint64_t kPeriodUs = 200000;  // rover.policy's follower
  ManualClock clock(kPeriodUs);
  perf::detail::TempDir dir;
  auto rig = perf::detail::Rig::make(dir.path + "/audit.jsonl", w, clock);
  if (!rig.ok()) {
    state.SkipWithError(rig.error().c_str());
    return;
  }
  w.job = {
      {0x01, 0x46, 80, 0x00, 0x00}, {0x01, 0x47, 80, 0x00, 0x00}, {0x01, 0x69, 0x00, 0x00, 0x00}};
  const std::vector<gate::Transfer> job = job_transfers(w);
  uint64_t failures = 0;
  size_t n = 0;
  for (auto _ : state) {
    if (n % job.size() == 0) {
      state.PauseTiming();
      clock.set_us(clock.now_us() + kPeriodUs);
      (*rig)->mon->sample_all();
      state.ResumeTiming();
    }
    const gate::TransferReply r = (*rig)->mon->transfer(w.task_id, job[n++ % job.size()]);
    failures += r.err != 0;
  }
  if (failures != 0) state.SkipWithError("a transfer failed");
  if (const std::string why = all_allowed(dir.path + "/audit.jsonl"); !why.empty())
    state.SkipWithError(why.c_str());
}
BENCHMARK(BM_MonitorTransferRover);

// One decision record, as the monitor writes it for the gripper's write.
void BM_AuditDecision(benchmark::State& state) {
  perf::detail::TempDir dir;
  monitor::AuditLog log;
  if (Status s = log.open(dir.path + "/audit.jsonl"); !s.ok()) {
    state.SkipWithError(s.error().c_str());
    return;
  }
  const uint8_t bytes[] = {0x1A, 0x00, 0x00, 0xA4, 0x01};
  core::AuditRecord r{};
  r.job = 12345;
  r.task = 1;
  r.device = 0;
  r.command = 3;
  r.rule = 2;
  r.index = 5;
  r.fields[0] = 0;
  r.fields[1] = 420;
  r.field_count = 2;
  r.bus = 1;
  r.addr = 0x40;
  r.original = bytes;
  r.original_len = sizeof bytes;
  const monitor::RecordNames names{"gripper", "arm", "LED", "grip_sequence"};
  uint64_t lost = 0;
  for (auto _ : state) {
    ++r.job;
    lost += log.decision(r, names) ? 0 : 1;
  }
  if (lost != 0) state.SkipWithError("a record was not written");
}
BENCHMARK(BM_AuditDecision);

// The SHA-256 of one such line (its "prev" chains the next): the floor of a
// record that is formatted for free.
void BM_AuditLineHash(benchmark::State& state) {
  const std::string line(static_cast<size_t>(state.range(0)), 'x');
  char out[65];
  for (auto _ : state) {
    monitor::sha256_hex(line, out);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_AuditLineHash)->Arg(64)->Arg(384);

}  // namespace
}  // namespace contego

BENCHMARK_MAIN();
