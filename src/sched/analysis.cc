#include "sched/analysis.h"

#include <algorithm>
#include <numeric>

namespace contego::sched {

Nanos checked_wcet(const Task& t) {
  return sat_add(t.wcet, sat_mul(t.actuations, std::max<Nanos>(t.overhead, 0)));
}

namespace {

// The interference sum_h ceil(r / T_h) C_h^TEE as r grows. Iterates never
// decrease, so ceil(r / T_h) changes only when r passes the end of the last
// job counted (jobs * T_h): most steps compare instead of dividing (the
// division was most of an analysis' time), and the sum is kept, not redone.
class Interference {
 public:
  // Keeps its counts in `jobs` and `covered` (an Analyzer's, reused).
  Interference(std::vector<Nanos>& jobs, std::vector<Nanos>& covered)
      : jobs_(jobs), covered_(covered) {}
  void reset(size_t n) {
    jobs_.assign(n, 0);
    covered_.assign(n, 0);
    total_ = 0;
  }
  // REQUIRES: r no smaller than at the previous call since reset(), r <= kMaxDuration.
  Nanos at(Nanos r, std::span<const Interferer> higher) {
    for (size_t k = 0; k < higher.size(); ++k) {
      if (r <= covered_[k]) continue;
      const Interferer& h = higher[k];
      const Nanos jobs = (r + h.period - 1) / h.period;  // ceil(r / T_h), r <= D fits
      total_ = sat_add(total_, sat_mul(jobs - jobs_[k], h.c_tee));
      jobs_[k] = jobs;
      covered_[k] = sat_mul(jobs, h.period);
    }
    return total_;
  }

 private:
  std::vector<Nanos>& jobs_;     // ceil(r / T_h) at the last r that moved it
  std::vector<Nanos>& covered_;  // jobs * T_h: the r up to which it holds
  Nanos total_ = 0;
};

Response response_time(Nanos c_tee, Nanos blocking, Nanos deadline,
                       std::span<const Interferer> higher, Interference& sum) {
  const Nanos own = sat_add(c_tee, blocking);
  Nanos r = own;
  if (r > deadline) return {r, false, 0};
  sum.reset(higher.size());
  for (int it = 1;; ++it) {
    const Nanos next = sat_add(own, sum.at(r, higher));
    // The whole iterate is reported, so a miss shows the paper's r^(alpha).
    if (next > deadline) return {next, false, it};
    if (next == r) return {r, true, it};
    r = next;  // iterates never decrease: each term is monotone in r
  }
}

bool meets_deadline(Nanos c_tee, Nanos blocking, Nanos deadline, std::span<const Interferer> higher,
                    Interference& sum) {
  const Nanos own = sat_add(c_tee, blocking);
  Nanos r = own;
  // Every interferer releases a job at 0, so a positive R_i holds at least
  // one job of each: starting there reaches the same least fixed point.
  if (own > 0) {
    for (const Interferer& h : higher) r = sat_add(r, h.c_tee);
  }
  sum.reset(higher.size());
  while (r <= deadline) {
    const Nanos next = sat_add(own, sum.at(r, higher));
    if (next == r) return true;
    r = next;  // iterates never decrease from a lower bound
  }
  return false;
}

}  // namespace

Response response_time(Nanos c_tee, Nanos blocking, Nanos deadline,
                       std::span<const Interferer> higher) {
  std::vector<Nanos> jobs, covered;
  Interference sum(jobs, covered);
  return response_time(c_tee, blocking, deadline, higher, sum);
}

bool meets_deadline(Nanos c_tee, Nanos blocking, Nanos deadline,
                    std::span<const Interferer> higher) {
  std::vector<Nanos> jobs, covered;
  Interference sum(jobs, covered);
  return meets_deadline(c_tee, blocking, deadline, higher, sum);
}

void Analyzer::prepare(const TaskSet& set) {
  const size_t n = set.tasks.size();
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), size_t{0});
  // Equal priorities keep the input's order: the index breaks ties, so a
  // plain sort does what a stable one would, without its buffer.
  std::sort(order_.begin(), order_.end(), [&](size_t a, size_t b) {
    const auto pa = set.tasks[a].priority;
    const auto pb = set.tasks[b].priority;
    return pa != pb ? pa > pb : a < b;
  });
  interferer_.resize(n);
  blocking_.resize(n);
  group_end_.resize(n);
  deadline_.resize(n);
  for (size_t p = 0; p < n; ++p) {
    const Task& t = set.tasks[order_[p]];
    interferer_[p] = {t.period, checked_wcet(t)};
    deadline_[p] = t.deadline;
  }
  // Group ends, then blocking as a suffix maximum over strictly lower
  // priorities: B at position p = max N_j C_j^o over positions >= group_end.
  for (size_t p = n; p-- > 0;) {
    const bool same_as_next =
        p + 1 < n && set.tasks[order_[p + 1]].priority == set.tasks[order_[p]].priority;
    group_end_[p] = same_as_next ? group_end_[p + 1] : p + 1;
  }
  std::vector<Nanos>& suffix = scratch_blocking_;  // max N_j C_j^o over positions >= q
  suffix.assign(n + 1, 0);
  for (size_t q = n; q-- > 0;) {
    const Task& t = set.tasks[order_[q]];
    suffix[q] = std::max(suffix[q + 1], sat_mul(t.actuations, std::max<Nanos>(t.overhead, 0)));
  }
  for (size_t q = 0; q < n; ++q) blocking_[q] = suffix[group_end_[q]];
}

std::span<const Interferer> Analyzer::higher(size_t pos) {
  const size_t end = group_end_[pos];
  // Distinct priority: hp(i) is exactly the positions before pos.
  if (end == pos + 1) return {interferer_.data(), pos};
  // Ties: every other member of the group interferes as well.
  scratch_.clear();
  for (size_t q = 0; q < end; ++q) {
    if (q != pos) scratch_.push_back(interferer_[q]);
  }
  return scratch_;
}

Response Analyzer::respond(size_t pos) {
  Interference sum(jobs_, covered_);
  return response_time(interferer_[pos].c_tee, blocking_[pos], deadline_[pos], higher(pos), sum);
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
  for (size_t p = 0; p < order_.size(); ++p) {
    const Response r = respond(p);
    TaskResult& tr = out.tasks[order_[p]];
    tr.c_tee = interferer_[p].c_tee;
    tr.blocking = blocking_[p];
    tr.response = r.response;
    tr.schedulable = r.schedulable;
    tr.iterations = r.iterations;
    tr.deadline = deadline_[p];
    out.schedulable = out.schedulable && r.schedulable;
  }
}

bool Analyzer::schedulable(const TaskSet& set) {
  prepare(set);
  Interference sum(jobs_, covered_);
  for (size_t p = 0; p < order_.size(); ++p) {
    if (!meets_deadline(interferer_[p].c_tee, blocking_[p], deadline_[p], higher(p), sum)) {
      return false;
    }
  }
  return true;
}

Analysis analyse(const TaskSet& set) { return Analyzer().analyse(set); }
bool is_schedulable(const TaskSet& set) { return Analyzer().schedulable(set); }

}  // namespace contego::sched
