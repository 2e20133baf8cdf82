// Policy closure (issue 5, item 3): what `contego check` reports about a
// policy's task model. Kept here, free of any policy or image type, so the
// policy compiler calls it with plain values and sched stays base-only.
//
// Host code.
#ifndef CONTEGO_SCHED_POLICY_CHECK_H_
#define CONTEGO_SCHED_POLICY_CHECK_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sched/task_set.h"

namespace contego::sched {

// A rate limit of the policy: `limit TASK -> DEVICE THETA per job`.
struct RateLimitInfo {
  std::string task;
  std::string target;       // device (and command set), for the message only
  int64_t max_per_job = 0;  // theta-hat
};

struct SchedWarning {
  std::string task;  // empty for set-wide findings
  std::string code;  // stable: "unschedulable", "rate-above-actuations", "no-overhead", "invalid"
  std::string message;  // lower-case, says what was observed and the rule
};

// Checks the task model of a policy:
//  - "invalid": the task model cannot be analysed (validate() failed);
//  - "no-overhead": no C^o declared and none given, the analysis assumes 0;
//  - "unschedulable": a task's R^TEE exceeds D at the configured overhead
//    (one warning per missing task, naming R bound and D);
//  - "rate-above-actuations": a rate limit theta-hat above the task's N
//    (the analysis budgets N checked commands per job; a limit that lets
//    more through makes the schedulability verdict unsound).
// `overhead`, when set, replaces the policy's C^o (e.g. a measured figure).
// With --strict the caller turns any warning into an error.
std::vector<SchedWarning> check_policy_tasks(const TaskSet& tasks,
                                             const std::vector<RateLimitInfo>& limits,
                                             std::optional<Nanos> overhead = std::nullopt);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_POLICY_CHECK_H_
