// Sensitivity analysis: how far the checking cost, a period or a task's
// number of checked commands can move before the exact test of
// sched/analysis.h fails. The test is monotone in each parameter (a larger
// C^o, N_i or a shorter T_i never shortens a response time), so each figure
// is a boundary, exact to the nanosecond / command.
//
// sensitivity() finds each figure over the scheduling intervals of the
// tasks it affects: a task's demand is constant between scheduling points,
// and over one interval linear in C^o and N_i and a step function of T_i,
// so what an interval admits is one division. The best interval is found
// by the response-time iteration itself, or by a branch and bound over time
// whose evaluations every search over the same task shares
// (sensitivity.cc); about 10-20 analyses per set. sensitivity_by_search()
// is the plain binary search on whole-set analyses (the reference the tests
// compare against, thousands of analyses per set).
//
// Host code.
#ifndef CONTEGO_SCHED_SENSITIVITY_H_
#define CONTEGO_SCHED_SENSITIVITY_H_

#include <cstdint>
#include <limits>
#include <vector>

#include "sched/task_set.h"

namespace contego::sched {

// The figure does not constrain the result (e.g. the task has no checked
// commands, so C^o never reaches it).
inline constexpr int64_t kUnbounded = std::numeric_limits<int64_t>::max();
// No value works, not even the smallest (the set already fails).
inline constexpr int64_t kInfeasible = -1;

struct TaskSensitivity {
  // Largest C^o, applied to every task alike, at which this task still
  // meets its deadline. The system-wide figure is the minimum of these.
  Nanos max_overhead = kInfeasible;
  // Smallest T_i (others unchanged) keeping the whole set schedulable; an
  // implicit deadline (D_i == T_i) shrinks with the period, a constrained
  // one stays, so T_i >= D_i.
  Nanos min_period = kInfeasible;
  // Largest N_i (others unchanged) keeping the whole set schedulable.
  int64_t max_actuations = kInfeasible;
};

struct Sensitivity {
  // Largest C^o, the same for every task, keeping the set schedulable:
  // "checking may cost up to X per command before a deadline is missed".
  Nanos max_overhead = kInfeasible;
  std::vector<TaskSensitivity> tasks;  // in the input's order
};

// REQUIRES: validate(set) succeeded, overheads resolved, priorities final.
Sensitivity sensitivity(const TaskSet& set);
Sensitivity sensitivity_by_search(const TaskSet& set);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_SENSITIVITY_H_
