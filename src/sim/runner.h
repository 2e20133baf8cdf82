// Runs a scenario in virtual time: releases the controllers' jobs, lets the
// attacks rewrite them, passes every bus operation through a guard, performs
// what the guard emits on the device models, and advances the plant with a
// fixed step. Deterministic: the same scenario, seed and guard give the same
// trace, byte for byte.
#ifndef CONTEGO_SIM_RUNNER_H_
#define CONTEGO_SIM_RUNNER_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "sim/guard.h"
#include "sim/scenario.h"

namespace contego::sim {

// One bus operation as it went through the guard.
struct OpRecord {
  uint64_t time_us;
  std::string task;
  uint16_t addr;
  bool read;
  std::vector<uint8_t> bytes;  // as the task sent it
  bool injected;               // written by an attack
  core::Decision decision;
  core::Reason reason;
  bool violation;
  std::vector<std::vector<uint8_t>> emitted;
};

struct RunStats {
  uint64_t writes = 0;  // write operations the tasks issued
  uint64_t reads = 0;
  uint64_t injected = 0;  // of which written by an attack
  uint64_t allowed = 0;   // writes that reached the device unchanged
  uint64_t ignored = 0;
  uint64_t replaced = 0;  // FAIL-SAFE: a substitute reached the device
  uint64_t rejected = 0;
  uint64_t violations = 0;  // verdicts that were not "allow" (observed even with protection off)
  std::optional<uint64_t> first_violation_us;

  // One operation at `t_us`: a write with the decision that acted, or a read;
  // `violation`: the core's verdict on it was not "allow".
  void count(bool write, core::Decision acted, bool violation, uint64_t t_us);
};

struct RunResult {
  std::string label;                 // "baseline", "unprotected", "protected"
  std::vector<std::string> columns;  // "time_s", then the world's columns
  std::vector<std::vector<double>> rows;
  std::vector<Event> events;
  std::vector<Metric> metrics;
  std::vector<OpRecord> ops;
  RunStats stats;
};

// Makes the guard for one run, given the bus it protects.
using GuardFactory = std::function<Result<std::unique_ptr<Guard>>(bus::VirtualBus& bus)>;

struct RunOptions {
  std::string label;
  bool attacks = true;           // false: the attack-free reference run
  GuardFactory guard;            // null: PassThroughGuard
  std::optional<uint64_t> seed;  // overrides the scenario's
};

Result<RunResult> run_scenario(const Scenario& scenario, const RunOptions& options);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_RUNNER_H_
