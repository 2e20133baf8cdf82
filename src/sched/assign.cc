#include "sched/assign.h"

#include <algorithm>
#include <numeric>
#include <utility>

#include "sched/analysis.h"

namespace contego::sched {
namespace {

// order[k] = index of the task that gets the k-th highest priority.
void apply_order(TaskSet& set, const std::vector<size_t>& order) {
  const auto n = static_cast<int64_t>(order.size());
  for (size_t k = 0; k < order.size(); ++k)
    set.tasks[order[k]].priority = n - static_cast<int64_t>(k);
}

std::vector<size_t> monotonic_order(const TaskSet& set, bool by_deadline) {
  std::vector<size_t> order(set.tasks.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const Task& x = set.tasks[a];
    const Task& y = set.tasks[b];
    const Nanos kx1 = by_deadline ? x.deadline : x.period;
    const Nanos ky1 = by_deadline ? y.deadline : y.period;
    if (kx1 != ky1) return kx1 < ky1;
    const Nanos kx2 = by_deadline ? x.period : x.deadline;
    const Nanos ky2 = by_deadline ? y.period : y.deadline;
    return kx2 < ky2;
  });
  return order;
}

}  // namespace

// One name a way, in the order of the enum; the parser and the printer both read it.
constexpr std::pair<Assignment, const char*> kAssignmentNames[] = {
    {Assignment::kGiven, "given"},
    {Assignment::kRateMonotonic, "rm"},
    {Assignment::kDeadlineMonotonic, "dm"},
    {Assignment::kAudsley, "audsley"},
};

Result<Assignment> parse_assignment(std::string_view text) {
  for (const auto& [how, name] : kAssignmentNames) {
    if (text == name) return how;
  }
  return make_error("unknown priority assignment '" + std::string(text) +
                    "' (use given, rm, dm or audsley)");
}

const char* assignment_name(Assignment a) {
  for (const auto& [how, name] : kAssignmentNames) {
    if (how == a) return name;
  }
  return "?";
}

Assigned assign_priorities(const TaskSet& set, Assignment how) {
  Assigned out{set, true};
  switch (how) {
    case Assignment::kGiven:
      return out;
    case Assignment::kRateMonotonic:
      apply_order(out.set, monotonic_order(set, false));
      return out;
    case Assignment::kDeadlineMonotonic:
      apply_order(out.set, monotonic_order(set, true));
      return out;
    case Assignment::kAudsley:
      break;
  }
  // Audsley: fill priority levels from the lowest up. At each level pick the
  // first unassigned task (in DM order, for a stable, sensible result) that
  // meets its deadline with every other unassigned task above it and the
  // assigned ones below it (which only contribute blocking).
  std::vector<size_t> unassigned = monotonic_order(set, true);
  std::vector<size_t> lowest_first;  // assigned, lowest priority first
  Nanos lp_blocking = 0;             // max N_j C_j^o over assigned tasks
  std::vector<Interferer> higher;
  while (!unassigned.empty()) {
    bool placed = false;
    for (size_t k = unassigned.size(); k-- > 0;) {  // try the longest deadline first
      const Task& cand = set.tasks[unassigned[k]];
      higher.clear();
      for (size_t other : unassigned) {
        if (other != unassigned[k]) {
          higher.push_back({set.tasks[other].period, checked_wcet(set.tasks[other])});
        }
      }
      if (response_time(checked_wcet(cand), lp_blocking, cand.deadline, higher).schedulable) {
        lp_blocking = std::max(lp_blocking, sat_mul(cand.actuations, cand.overhead));
        lowest_first.push_back(unassigned[k]);
        unassigned.erase(unassigned.begin() + static_cast<std::ptrdiff_t>(k));
        placed = true;
        break;
      }
    }
    if (!placed) {
      // No task can take this level: by optimality no order works. The rest
      // keep DM order above the levels already filled.
      out.found = false;
      for (size_t k = unassigned.size(); k-- > 0;) lowest_first.push_back(unassigned[k]);
      break;
    }
  }
  std::vector<size_t> order(lowest_first.rbegin(), lowest_first.rend());
  apply_order(out.set, order);
  return out;
}

}  // namespace contego::sched
