// Response-time analysis with checking overhead (the paper's appendix).
//
//   C_i^TEE = C_i + N_i * C_i^o
//   B_i     = max over tau_j in lp(i) of N_j * C_j^o
//   r_i     = C_i^TEE + B_i + sum over tau_h in hp(i) of ceil(r_i / T_h) * C_h^TEE
//
// solved by fixed-point iteration from r = C_i^TEE + B_i (the iterate the
// paper's r^(0) = 0 reaches after one step), declaring tau_i unschedulable
// as soon as an iterate exceeds D_i. Uniprocessor, fixed-priority
// preemptive, D_i <= T_i. Tasks of equal priority count as each other's
// higher-priority interference (safe for SCHED_FIFO's FIFO order among
// equals); only strictly lower priorities contribute blocking.
//
// Integer nanoseconds, saturating arithmetic: no input can make an iterate
// wrap around. Host code; an Analyzer reuses its buffers, so it allocates
// only while growing and is not thread-safe (use one per thread). The free
// functions analyse() and is_schedulable() keep one Analyzer per thread.
#ifndef CONTEGO_SCHED_ANALYSIS_H_
#define CONTEGO_SCHED_ANALYSIS_H_

#include <cstdint>
#include <span>
#include <vector>

#include "sched/task_set.h"

namespace contego::sched {

struct TaskResult {
  Nanos c_tee = 0;     // C_i^TEE
  Nanos blocking = 0;  // B_i
  // R_i^TEE when schedulable; otherwise the first iterate beyond D_i, a
  // lower bound of the true response time (the iteration stops there).
  Nanos response = 0;
  bool schedulable = false;
  int iterations = 0;  // recurrence steps taken
  Nanos deadline = 0;  // D_i, copied for slack()
  // D_i - R_i^TEE; negative when the task misses (then only a bound).
  Nanos slack() const { return deadline - response; }
};

struct Analysis {
  std::vector<TaskResult> tasks;  // in the input's order
  bool schedulable = false;       // every task meets its deadline
};

// One higher-priority task as seen by the recurrence.
struct Interferer {
  Nanos period = 0;
  Nanos c_tee = 0;
};

struct Response {
  Nanos response = 0;
  bool schedulable = false;
  int iterations = 0;
};

// C_i + N_i * C_i^o (saturating). REQUIRES: overhead resolved (>= 0).
Nanos checked_wcet(const Task& t);

// The recurrence for one task, given its higher-priority interferers.
Response response_time(Nanos c_tee, Nanos blocking, Nanos deadline,
                       std::span<const Interferer> higher);

// Whether the recurrence's least fixed point is within `deadline` (the same
// verdict as response_time), starting from C_i + B_i + sum of C_j^TEE: a
// lower bound on R_i whenever R_i > 0, so it skips the first iterates.
bool meets_deadline(Nanos c_tee, Nanos blocking, Nanos deadline,
                    std::span<const Interferer> higher);

class Analyzer {
 public:
  // REQUIRES: validate(set) succeeded and overheads are resolved.
  Analysis analyse(const TaskSet& set);
  // The same into `out`, reusing its storage (no allocation once it has
  // held a set as large).
  void analyse(const TaskSet& set, Analysis& out);
  // Same verdict as analyse(set).schedulable, stopping at the first miss.
  bool schedulable(const TaskSet& set);

 private:
  // A task at its priority position. The recurrence of a lower position
  // reads period, c_tee and covered (the end of the last of this task's
  // jobs it has counted) and writes covered.
  struct Slot {
    Nanos period = 0;
    Nanos c_tee = 0;
    Nanos covered = 0;
    Nanos blocking = 0;
    Nanos deadline = 0;
    size_t group_end = 0;  // first position of strictly lower priority
  };
  struct Key {
    int64_t priority = 0;
    size_t index = 0;  // in the input
  };
  // Sorts by priority and computes C^TEE, blocking and group bounds.
  void prepare(const TaskSet& set);
  // The recurrence of position `pos`; `from_lower_bound` starts it at
  // C^TEE + B + the sum of its interferers' C^TEE (meets_deadline).
  Response respond(size_t pos, bool from_lower_bound);

  std::vector<Key> order_;  // by position: decreasing priority, then input order
  std::vector<Slot> slot_;  // by position
};

Analysis analyse(const TaskSet& set);
bool is_schedulable(const TaskSet& set);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_ANALYSIS_H_
