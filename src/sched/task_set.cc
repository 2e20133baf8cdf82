#include "sched/task_set.h"

#include <set>

namespace contego::sched {
namespace {

Error task_error(const Task& t, size_t index, const std::string& what) {
  const std::string who =
      t.name.empty() ? "task #" + std::to_string(index + 1) : "task '" + t.name + "'";
  return make_error(who + ": " + what);
}

}  // namespace

Status validate(const TaskSet& set) {
  if (set.tasks.empty()) return make_error("the task set is empty");
  if (set.overhead && (*set.overhead < 0 || *set.overhead > kMaxDuration)) {
    return make_error("set-wide overhead out of range");
  }
  std::set<std::string> names;
  for (size_t i = 0; i < set.tasks.size(); ++i) {
    const Task& t = set.tasks[i];
    if (t.name.empty()) return task_error(t, i, "has no name");
    if (!names.insert(t.name).second) return task_error(t, i, "name used twice");
    if (t.wcet <= 0 || t.wcet > kMaxDuration) return task_error(t, i, "wcet must be > 0");
    if (t.period <= 0 || t.period > kMaxDuration) return task_error(t, i, "period must be > 0");
    if (t.deadline <= 0) return task_error(t, i, "deadline must be > 0");
    if (t.deadline > t.period) {
      return task_error(t, i,
                        "deadline " + format_duration(t.deadline) + " exceeds period " +
                            format_duration(t.period) +
                            "; deadlines beyond the period (arbitrary deadlines) are not "
                            "supported by this analysis");
    }
    if (t.actuations < 0 || t.actuations > 1'000'000) {
      return task_error(t, i, "actuations must be between 0 and 1000000");
    }
    if (t.overhead != kOverheadUnset && (t.overhead < 0 || t.overhead > kMaxDuration)) {
      return task_error(t, i, "overhead out of range");
    }
  }
  return {};
}

TaskSet resolve_overheads(TaskSet set, std::optional<Nanos> forced, Nanos fallback) {
  for (Task& t : set.tasks) {
    if (forced) {
      t.overhead = *forced;
    } else if (t.overhead == kOverheadUnset) {
      t.overhead = set.overhead.value_or(fallback);
    }
  }
  return set;
}

double utilisation(const TaskSet& set) {
  double u = 0;
  for (const Task& t : set.tasks) u += static_cast<double>(t.wcet) / static_cast<double>(t.period);
  return u;
}

double utilisation_with_checking(const TaskSet& set) {
  double u = 0;
  for (const Task& t : set.tasks) {
    const Nanos c = sat_add(t.wcet, sat_mul(t.actuations, t.overhead < 0 ? 0 : t.overhead));
    u += static_cast<double>(c) / static_cast<double>(t.period);
  }
  return u;
}

}  // namespace contego::sched
