// Priority assignment for the analysis in sched/analysis.h: keep the given
// priorities, rate-monotonic, deadline-monotonic, or Audsley's optimal
// priority assignment (OPA). docs/sched.md argues why OPA stays optimal for
// this test with the blocking term; assign_test.cc checks it against
// exhaustive search.
//
// Host code.
#ifndef CONTEGO_SCHED_ASSIGN_H_
#define CONTEGO_SCHED_ASSIGN_H_

#include <string_view>

#include "base/result.h"
#include "sched/task_set.h"

namespace contego::sched {

enum class Assignment { kGiven, kRateMonotonic, kDeadlineMonotonic, kAudsley };

// "given", "rm", "dm", "audsley".
Result<Assignment> parse_assignment(std::string_view text);
const char* assignment_name(Assignment a);

struct Assigned {
  TaskSet set;  // priorities rewritten to n (highest) .. 1, except for kGiven
  // kAudsley only: false when no priority order makes the set schedulable
  // (the remaining tasks then get deadline-monotonic priorities).
  bool found = true;
};

// REQUIRES: validate(set) succeeded and overheads are resolved (Audsley
// runs the test). Ties in RM/DM break on deadline/period, then input order.
Assigned assign_priorities(const TaskSet& set, Assignment how);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_ASSIGN_H_
