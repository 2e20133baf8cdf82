// The task model of the paper's appendix: periodic tasks tau_i = (C_i, T_i,
// D_i) with a fixed priority, N_i checked actuation commands per job, and a
// per-command checking cost C_i^o (world switch + check + bus transfer when
// the checker performs it).
//
// Host code, plain values. Times are integer nanoseconds (sched/duration.h).
#ifndef CONTEGO_SCHED_TASK_SET_H_
#define CONTEGO_SCHED_TASK_SET_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "sched/duration.h"

namespace contego::sched {

// C_i^o not given for this task: the set-wide value applies.
inline constexpr Nanos kOverheadUnset = -1;

struct Task {
  std::string name;
  Nanos wcet = 0;                   // C_i: worst-case execution time without any checking
  Nanos period = 0;                 // T_i
  Nanos deadline = 0;               // D_i, relative; the analysis requires D_i <= T_i
  int64_t priority = 0;             // larger = more important (Linux SCHED_FIFO)
  int64_t actuations = 0;           // N_i: checked commands per job
  Nanos overhead = kOverheadUnset;  // C_i^o
};

struct TaskSet {
  std::vector<Task> tasks;
  // Set-wide C^o declared by the input (a policy's `overhead`, a JSON
  // file's "overhead"); used for tasks whose own overhead is unset.
  std::optional<Nanos> overhead;
  // False when the input carried no priorities (then one of the assignment
  // rules of sched/assign.h must be chosen).
  bool priorities_given = true;
};

// Checks what the analysis relies on: at least one task, unique non-empty
// names, C_i > 0, T_i > 0, 0 < D_i <= T_i (deadlines beyond the period are
// refused: the appendix's recurrence looks at one job per busy period, which
// is only sound when D_i <= T_i), N_i >= 0, C_i^o >= 0 when set, and every
// duration at most kMaxDuration. The error names the task and the field.
Status validate(const TaskSet& set);

// Gives every task a concrete C_i^o. `forced`, when present, replaces every
// task's value (the --overhead flag); otherwise a task keeps its own, then
// the set's, then `fallback`.
TaskSet resolve_overheads(TaskSet set, std::optional<Nanos> forced, Nanos fallback);

// Sum of C_i / T_i and of C_i^TEE / T_i (for reports; never used in a decision).
double utilisation(const TaskSet& set);
double utilisation_with_checking(const TaskSet& set);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_TASK_SET_H_
