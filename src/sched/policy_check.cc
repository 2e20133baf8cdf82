#include "sched/policy_check.h"

#include <map>

#include "sched/analysis.h"

namespace contego::sched {

std::vector<SchedWarning> check_policy_tasks(const TaskSet& tasks,
                                             const std::vector<RateLimitInfo>& limits,
                                             std::optional<Nanos> overhead) {
  std::vector<SchedWarning> out;
  std::map<std::string, int64_t> actuations;
  for (const Task& t : tasks.tasks) actuations[t.name] = t.actuations;
  // theta-hat counts commands per job to one target; N counts all of a
  // job's checked commands, so even one limit above N is a contradiction.
  for (const RateLimitInfo& l : limits) {
    const auto it = actuations.find(l.task);
    if (it == actuations.end()) continue;  // unknown tasks are the compiler's error
    if (l.max_per_job > it->second) {
      out.push_back({l.task, "rate-above-actuations",
                     "rate limit of " + std::to_string(l.max_per_job) + " per job on " + l.target +
                         " exceeds the task's " + std::to_string(it->second) +
                         " actuations per job; the schedulability analysis budgets only " +
                         std::to_string(it->second) +
                         " checked commands, so raise `actuations` or lower the limit"});
    }
  }
  if (Status st = validate(tasks); !st.ok()) {
    out.push_back({"", "invalid", "task model cannot be analysed: " + st.error()});
    return out;
  }
  bool declared = tasks.overhead.has_value();
  for (const Task& t : tasks.tasks) declared = declared || t.overhead != kOverheadUnset;
  if (!overhead && !declared) {
    out.push_back({"", "no-overhead",
                   "no checking overhead declared; schedulability assumes checking is free "
                   "(declare `overhead`, measured with `contego bench`)"});
  }
  const TaskSet resolved = resolve_overheads(tasks, overhead, 0);
  const Analysis a = analyse(resolved);
  for (size_t i = 0; i < a.tasks.size(); ++i) {
    const TaskResult& r = a.tasks[i];
    if (r.schedulable) continue;
    const Task& t = resolved.tasks[i];
    out.push_back({t.name, "unschedulable",
                   "task '" + t.name + "' can miss its deadline: response time exceeds " +
                       format_duration(r.response) + " > deadline " + format_duration(t.deadline) +
                       " at " + format_duration(t.overhead) + " per checked command"});
  }
  return out;
}

}  // namespace contego::sched
