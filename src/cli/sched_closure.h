// The schedulability closure of `contego check --strict`: the policy's task
// model (from the compiled image) through the response-time analysis of
// src/sched. Kept out of src/policy so the compiler does not depend on sched;
// the CLI and the golden tests hand it to the compiler as a callback.
#ifndef CONTEGO_CLI_SCHED_CLOSURE_H_
#define CONTEGO_CLI_SCHED_CLOSURE_H_

#include <string>
#include <vector>

#include "image/image_model.h"
#include "policy/compile.h"
#include "sched/policy_check.h"

namespace contego::cli {

// The image's task records as the analysis' task set (microseconds to
// nanoseconds; an overhead of 0 in the record means "not declared").
inline sched::TaskSet tasks_from_image(const image::ImageModel& model) {
  sched::TaskSet set;
  for (const auto& t : model.tasks) {
    sched::Task task;
    task.name = t.name;
    task.wcet = sched::Nanos{t.record.wcet_us} * 1000;
    task.period = sched::Nanos{t.record.period_us} * 1000;
    task.deadline = sched::Nanos{t.record.deadline_us} * 1000;
    task.priority = t.record.priority;
    task.actuations = t.record.actuations_per_job;
    task.overhead =
        t.record.overhead_ns ? sched::Nanos{t.record.overhead_ns} : sched::kOverheadUnset;
    set.tasks.push_back(task);
  }
  return set;
}

inline std::vector<policy::TaskFinding> sched_closure(const image::ImageModel& model) {
  const sched::TaskSet set = tasks_from_image(model);
  std::vector<sched::RateLimitInfo> limits;
  for (const auto& r : model.rates) {
    if (r.record.task >= model.tasks.size()) continue;
    limits.push_back({model.tasks[r.record.task].name, r.name, r.record.max_per_job});
  }
  std::vector<policy::TaskFinding> out;
  for (const auto& w : sched::check_policy_tasks(set, limits)) {
    // The compiler reports rate limits above N itself (W0702); a policy
    // without `overhead` is analysed with C^o = 0 and says so in its summary.
    if (w.code == "rate-above-actuations" || w.code == "no-overhead") continue;
    out.push_back({w.task, w.message});
  }
  return out;
}

}  // namespace contego::cli

#endif  // CONTEGO_CLI_SCHED_CLOSURE_H_
