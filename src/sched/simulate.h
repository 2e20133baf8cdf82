// A discrete-event simulator of fixed-priority preemptive scheduling on one
// core, with each checked command as a non-preemptive section of C_i^o: the
// independent check of the analysis in sched/analysis.h (simulated response
// times must never exceed the analytic bound; without checking sections and
// with synchronous release they must equal it).
//
// A job of tau_i is C_i of preemptive computation split into N_i + 1 equal
// chunks with one checking section after each of the first N_i chunks
// (compute, check, compute, check, ..., compute). Once started, a checking
// section runs to its end. Among equal priorities the running job keeps the
// processor and waiting jobs run in release order (SCHED_FIFO). Jobs are
// never aborted; a late job simply finishes late.
//
// Host code; time and memory grow with the number of jobs in the horizon.
#ifndef CONTEGO_SCHED_SIMULATE_H_
#define CONTEGO_SCHED_SIMULATE_H_

#include <cstdint>
#include <vector>

#include "base/result.h"
#include "sched/task_set.h"

namespace contego::sched {

struct SimOptions {
  // First release of each task (empty: all at 0, the synchronous pattern).
  std::vector<Nanos> offsets;
  // Jobs are released in [0, horizon) and followed until they finish;
  // 0 means max offset + hyperperiod.
  Nanos horizon = 0;
  // Refuse task sets whose hyperperiod exceeds this (the simulation would
  // be long): the error says so.
  Nanos max_hyperperiod = 10 * kNanosPerSecond;
};

struct SimTaskStats {
  Nanos max_response = 0;
  int64_t jobs = 0;    // jobs released in the horizon, all followed to completion
  int64_t misses = 0;  // of those, finished after their deadline
};

struct SimResult {
  Nanos hyperperiod = 0;
  std::vector<SimTaskStats> tasks;  // in the input's order
};

// Least common multiple of the periods; an error if it exceeds `limit`.
Result<Nanos> hyperperiod(const TaskSet& set, Nanos limit);

// REQUIRES: overheads resolved. Validates the set first.
Result<SimResult> simulate(const TaskSet& set, const SimOptions& options = {});

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_SIMULATE_H_
