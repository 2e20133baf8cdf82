// The in-process enclave path (`contego bench`'s path d) piece by piece:
// one checked transfer through monitor::Monitor with the compiled example
// policy (arm.policy's gripper write, the bench's arm row), with and without
// its audit record, and the audit record alone. ns per call; run it under
// callgrind for instructions. Release preset for real figures:
//   build/release/bench/monitor_bench
#include <benchmark/benchmark.h>
#include <cstdlib>
#include <string>

#include "base/read_file.h"
#include "monitor/audit_log.h"
#include "perf/rig.h"
#include "policy/compile.h"

namespace contego {
namespace {

std::string policy_path(const char* file) {
  const char* dir = std::getenv("CONTEGO_POLICY_DIR");
  return std::string(dir != nullptr ? dir : CONTEGO_SOURCE_POLICIES) + "/" + file;
}

// arm.policy's gripper setting LED5 to off=420 (the bench's arm row).
perf::Workload arm_gripper() {
  perf::Workload w;
  const std::string path = policy_path("arm.policy");
  Result<std::string> text = read_input_file(path);
  if (!text) return w;
  const policy::CompileOutput out = policy::compile_source(path, *text);
  if (!out.ok) return w;
  w.name = "arm.policy gripper";
  w.task = "gripper";
  w.addr = 0x40;
  w.bytes = {0x1A, 0x00, 0x00, 0xA4, 0x01};
  w.image = out.image;
  for (size_t i = 0; i < out.model.tasks.size(); ++i) {
    if (out.model.tasks[i].name == "gripper") w.task_id = static_cast<uint16_t>(i);
  }
  return w;
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

// Monitor::transfer of the gripper write; `audited`: to a file in /tmp (the
// bench's rig), else no log at all.
void BM_MonitorTransfer(benchmark::State& state, bool audited) {
  const perf::Workload w = arm_gripper();
  if (w.image.empty()) {
    state.SkipWithError("arm.policy did not compile (set CONTEGO_POLICY_DIR)");
    return;
  }
  perf::detail::TempDir dir;
  auto rig = perf::detail::Rig::make(audited ? dir.path + "/audit.jsonl" : "", w);
  if (!rig.ok()) {
    state.SkipWithError(rig.error().c_str());
    return;
  }
  const gate::Transfer t = one_write(w);
  uint64_t failures = 0;
  for (auto _ : state) {
    const gate::TransferReply r = (*rig)->mon->transfer(w.task_id, t);
    failures += r.err != 0;
  }
  if (failures != 0) state.SkipWithError("a transfer failed");
}
BENCHMARK_CAPTURE(BM_MonitorTransfer, audited, true);
BENCHMARK_CAPTURE(BM_MonitorTransfer, unaudited, false);

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

}  // namespace
}  // namespace contego

BENCHMARK_MAIN();
