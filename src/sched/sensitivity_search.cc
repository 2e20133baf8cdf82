// The reference sensitivity search: binary searches of whole-set analyses.
// Slow (hundreds of analyses per set) and obviously right; the tests hold
// sensitivity() (sensitivity.cc) to it.
#include <algorithm>

#include "sched/analysis.h"
#include "sched/sensitivity.h"

namespace contego::sched {
namespace {

// Largest x in [lo, hi] with ok(x), given ok(lo) and monotone ok (true then
// false). Returns lo when only lo works.
template <typename Ok>
int64_t largest_ok(int64_t lo, int64_t hi, Ok ok) {
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo + 1) / 2;
    if (ok(mid)) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  return lo;
}

// Smallest x in [lo, hi] with ok(x), given ok(hi) and monotone ok.
template <typename Ok>
int64_t smallest_ok(int64_t lo, int64_t hi, Ok ok) {
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo) / 2;
    if (ok(mid)) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return hi;
}

}  // namespace

Sensitivity sensitivity_by_search(const TaskSet& set) {
  Analyzer analyzer;
  const size_t n = set.tasks.size();
  Sensitivity out;
  out.tasks.resize(n);

  // Per-task tolerance of a uniform C^o. Every other task is either above
  // tau_i (interference >= N_j C^o) or below it (blocking >= N_j C^o), so
  // once any task has a checked command, C^o > D_i makes tau_i miss: the
  // search stays within [0, D_i]. With no checked command anywhere, C^o
  // cannot matter and the figure is kUnbounded.
  TaskSet uniform = set;
  auto task_ok_at = [&](size_t i, Nanos c_o) {
    for (Task& t : uniform.tasks) t.overhead = c_o;
    return analyzer.analyse(uniform).tasks[i].schedulable;
  };
  const bool any_checks = std::any_of(set.tasks.begin(), set.tasks.end(),
                                      [](const Task& t) { return t.actuations > 0; });
  for (size_t i = 0; i < n; ++i) {
    TaskSensitivity& s = out.tasks[i];
    if (!task_ok_at(i, 0)) {
      s.max_overhead = kInfeasible;
    } else if (!any_checks) {
      s.max_overhead = kUnbounded;
    } else {
      s.max_overhead =
          largest_ok(0, set.tasks[i].deadline, [&](Nanos c) { return task_ok_at(i, c); });
    }
  }
  out.max_overhead = kUnbounded;
  for (const TaskSensitivity& s : out.tasks)
    out.max_overhead = std::min(out.max_overhead, s.max_overhead);

  const bool feasible = analyzer.schedulable(set);
  TaskSet probe = set;
  for (size_t i = 0; i < n; ++i) {
    TaskSensitivity& s = out.tasks[i];
    const Task original = set.tasks[i];
    if (!feasible) {
      s.min_period = kInfeasible;
      s.max_actuations = kInfeasible;
      continue;
    }
    // Smallest period. The task cannot run faster than its own C_i^TEE.
    const bool implicit = original.deadline == original.period;
    auto period_ok = [&](Nanos t) {
      probe.tasks[i].period = t;
      probe.tasks[i].deadline = implicit ? t : original.deadline;
      return analyzer.schedulable(probe);
    };
    const Nanos low = implicit ? std::max<Nanos>(1, checked_wcet(original)) : original.deadline;
    s.min_period = smallest_ok(std::min(low, original.period), original.period, period_ok);
    probe.tasks[i] = original;

    // Largest N_i.
    if (original.overhead <= 0) {
      s.max_actuations = kUnbounded;  // checking is free for this task
    } else {
      auto n_ok = [&](int64_t k) {
        probe.tasks[i].actuations = k;
        return analyzer.schedulable(probe);
      };
      const int64_t top = original.deadline / original.overhead + 1;  // C^TEE > D beyond
      s.max_actuations = largest_ok(original.actuations, std::max(top, original.actuations), n_ok);
      probe.tasks[i] = original;
    }
  }
  return out;
}

}  // namespace contego::sched
