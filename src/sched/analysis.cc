#include "sched/analysis.h"

#include <algorithm>
#include <limits>

namespace contego::sched {

Nanos checked_wcet(const Task& t) {
  return sat_add(t.wcet, sat_mul(t.actuations, std::max<Nanos>(t.overhead, 0)));
}

namespace {

// The interference sum_h ceil(r / T_h) C_h^TEE as r grows. Iterates never
// decrease, so each interferer's count of jobs only grows, and only when r
// passes the end of the last job counted (`covered`): an interferer that
// releases nothing new costs one comparison, one that releases one more
// job an addition, and only a jump over more than one period divides. The
// sum is kept, not redone.
template <typename Slot>
struct Interference {
  Nanos total = 0;
  // The smallest `covered` after the last add(): while r stays at or below
  // it, no interferer releases another job and the sum cannot change.
  Nanos next_release = std::numeric_limits<Nanos>::max();

  // The first step: counts the jobs of slots [first, first + n) released
  // before r, whatever their covered held.
  void begin(Slot* first, size_t n, Nanos r) {
    Nanos low = next_release;
    for (Slot* h = first; h != first + n; ++h) {
      Nanos covered = h->period;
      Nanos jobs = 1;
      if (r > h->period) [[unlikely]] {
        jobs = (r + h->period - 1) / h->period;
        covered = jobs * h->period;  // < r + T_h: no overflow below kMaxDuration
      } else if (r == 0) [[unlikely]] {
        jobs = 0;
        covered = 0;
      }
      total = sat_add(total, sat_mul(jobs, h->c_tee));
      h->covered = covered;
      low = std::min(low, covered);
    }
    next_release = low;
  }

  // A later step: counts the jobs released in [covered, r) of each slot.
  // REQUIRES: begin() on these slots, then r no smaller than at the previous
  // call, r <= kMaxDuration.
  void add(Slot* first, size_t n, Nanos r) {
    Nanos low = next_release;
    for (Slot* h = first; h != first + n; ++h) {
      Nanos covered = h->covered;
      if (r - covered > h->period) [[unlikely]] {
        // More than one new job: one division.
        const Nanos more = (r - covered + h->period - 1) / h->period;
        covered += more * h->period;
        total = sat_add(total, sat_mul(more, h->c_tee));
      } else {
        // At most one: a select, not a branch (which way it goes is data).
        const bool released = r > covered;
        covered += released ? h->period : 0;
        total = sat_add(total, released ? h->c_tee : 0);
      }
      h->covered = covered;
      low = std::min(low, covered);
    }
    next_release = low;
  }
};

// The recurrence from `start` over the interferers [a, a + na) and
// [b, b + nb). Reports the paper's iterates:
// the first beyond `deadline` on a miss, the step count to the fixed point.
template <typename Slot>
Response iterate(Nanos own, Nanos start, Nanos deadline, Slot* a, size_t na, Slot* b, size_t nb) {
  Nanos r = start;
  if (r > deadline) return {r, false, 0};
  Interference<Slot> sum;
  for (int it = 1;; ++it) {
    sum.next_release = std::numeric_limits<Nanos>::max();
    if (it == 1) {
      sum.begin(a, na, r);
      sum.begin(b, nb, r);
    } else {
      sum.add(a, na, r);
      sum.add(b, nb, r);
    }
    const Nanos next = sat_add(own, sum.total);
    // The whole iterate is reported, so a miss shows the paper's r^(alpha).
    if (next > deadline) return {next, false, it};
    if (next == r) return {r, true, it};
    // Iterates never decrease: each term is monotone in r. Up to the next
    // release the sum stays, so the next step would give `next` again.
    if (next <= sum.next_release) return {next, true, it + 1};
    r = next;
  }
}

struct Plain {
  Nanos period = 0;
  Nanos c_tee = 0;
  Nanos covered = 0;
};

std::vector<Plain> plain_slots(std::span<const Interferer> higher) {
  std::vector<Plain> slots(higher.size());
  for (size_t k = 0; k < higher.size(); ++k) slots[k] = {higher[k].period, higher[k].c_tee};
  return slots;
}

}  // namespace

Response response_time(Nanos c_tee, Nanos blocking, Nanos deadline,
                       std::span<const Interferer> higher) {
  std::vector<Plain> slots = plain_slots(higher);
  const Nanos own = sat_add(c_tee, blocking);
  return iterate(own, own, deadline, slots.data(), slots.size(), slots.data(), 0);
}

bool meets_deadline(Nanos c_tee, Nanos blocking, Nanos deadline,
                    std::span<const Interferer> higher) {
  std::vector<Plain> slots = plain_slots(higher);
  const Nanos own = sat_add(c_tee, blocking);
  // Every interferer releases a job at 0, so a positive R_i holds at least
  // one job of each: starting there reaches the same least fixed point.
  Nanos start = own;
  if (own > 0) {
    for (const Interferer& h : higher) start = sat_add(start, h.c_tee);
  }
  return iterate(own, start, deadline, slots.data(), slots.size(), slots.data(), 0).schedulable;
}

void Analyzer::prepare(const TaskSet& set) {
  const size_t n = set.tasks.size();
  order_.resize(n);
  bool sorted = true;
  for (size_t i = 0; i < n; ++i) {
    order_[i] = {set.tasks[i].priority, i};
    sorted = sorted && (i == 0 || order_[i - 1].priority >= order_[i].priority);
  }
  // Equal priorities keep the input's order: the index breaks ties, so a
  // plain sort does what a stable one would, without its buffer. Input
  // already in priority order (the usual file) is not sorted again.
  if (!sorted) {
    std::sort(order_.begin(), order_.end(), [](const Key& a, const Key& b) {
      return a.priority != b.priority ? a.priority > b.priority : a.index < b.index;
    });
  }
  slot_.resize(n);
  // From the lowest priority up: group ends, and blocking as the largest
  // N_j C_j^o below the group (strictly lower priorities only).
  Nanos below = 0;  // over the groups below the current one
  Nanos group = 0;  // over the current group's members seen so far
  for (size_t p = n; p-- > 0;) {
    const Task& t = set.tasks[order_[p].index];
    const bool same_as_next = p + 1 < n && order_[p + 1].priority == order_[p].priority;
    if (!same_as_next) {
      below = std::max(below, group);
      group = 0;
    }
    const Nanos checking = sat_mul(t.actuations, std::max<Nanos>(t.overhead, 0));
    group = std::max(group, checking);
    slot_[p] = {t.period,   sat_add(t.wcet, checking),
                0,          below,
                t.deadline, same_as_next ? slot_[p + 1].group_end : p + 1};
  }
}

Response Analyzer::respond(size_t pos, bool from_lower_bound) {
  Slot* const s = slot_.data();
  const Slot& me = s[pos];
  const size_t end = me.group_end;
  const Nanos own = sat_add(me.c_tee, me.blocking);
  Nanos start = own;
  // hp(i) is the positions before pos, and the other members of its group.
  if (from_lower_bound && own > 0) {
    for (size_t q = 0; q < end; ++q) start = sat_add(start, q != pos ? s[q].c_tee : 0);
  }
  return iterate(own, start, me.deadline, s, pos, s + pos + 1, end - pos - 1);
}

Analysis Analyzer::analyse(const TaskSet& set) {
  Analysis out;
  analyse(set, out);
  return out;
}

void Analyzer::analyse(const TaskSet& set, Analysis& out) {
  prepare(set);
  out.tasks.resize(set.tasks.size());
  out.schedulable = true;
  for (size_t p = 0; p < slot_.size(); ++p) {
    const Response r = respond(p, false);
    const Slot& me = slot_[p];
    TaskResult& tr = out.tasks[order_[p].index];
    tr.c_tee = me.c_tee;
    tr.blocking = me.blocking;
    tr.response = r.response;
    tr.schedulable = r.schedulable;
    tr.iterations = r.iterations;
    tr.deadline = me.deadline;
    out.schedulable = out.schedulable && r.schedulable;
  }
}

bool Analyzer::schedulable(const TaskSet& set) {
  prepare(set);
  for (size_t p = 0; p < slot_.size(); ++p) {
    if (!respond(p, true).schedulable) return false;
  }
  return true;
}

Analysis analyse(const TaskSet& set) {
  thread_local Analyzer analyzer;
  return analyzer.analyse(set);
}
bool is_schedulable(const TaskSet& set) {
  thread_local Analyzer analyzer;
  return analyzer.schedulable(set);
}

}  // namespace contego::sched
