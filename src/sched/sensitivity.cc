// Sensitivity by scheduling points (see sensitivity.h). Every figure equals
// the binary search of sensitivity_search.cc; sensitivity_test.cc checks it
// on thousands of random sets.
//
// The fact used throughout: task p's demand W(t) = own + sum over hp of
// ceil(t/T_h) C_h^TEE is constant on the intervals between scheduling
// points (multiples of higher-priority periods, and D_p), so p meets its
// deadline iff W(b) <= b at the right end b of some interval up to D_p, and
// only intervals from its response time R on can hold one (W(t) > t below
// R, and every parameter here only moves W up). Over one interval W is
// linear in a uniform C^o and in N_i, and a step function of T_i, so the
// largest C^o, largest N_i or smallest T_i an interval admits is one
// division; a task's figure is the best over its intervals in [R, D], found
// by walking them in order (a heap of next releases) and stopping once no
// later interval can do better.
//
// For T_i and N_i, which bind through every task they affect, the interval
// holding each task's R gives a cheap bound first (a value at which it is
// known to pass); a task is walked only when its bound could decide the
// figure, which is rarely more than one or two per figure.
#include <algorithm>
#include <numeric>

#include "sched/analysis.h"
#include "sched/sensitivity.h"

namespace contego::sched {
namespace {

Nanos ceil_div(Nanos a, Nanos b) { return (a + b - 1) / b; }

struct Fix {
  Nanos t = 0;       // least fixed point (or the first iterate beyond D)
  bool ok = false;   // t <= D
  Nanos demand = 0;  // W(t) <= t
  Nanos next = 0;    // the right end of t's interval (the next scheduling point, at most D)
};

class Model {
 public:
  explicit Model(const TaskSet& set) : n(set.tasks.size()) {
    order.resize(n);
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return set.tasks[a].priority > set.tasks[b].priority;
    });
    for (size_t p = 0; p < n; ++p) {
      const Task& t = set.tasks[order[p]];
      wcet.push_back(t.wcet);
      period.push_back(t.period);
      deadline.push_back(t.deadline);
      actuations.push_back(t.actuations);
      overhead.push_back(std::max<Nanos>(t.overhead, 0));
      c_tee.push_back(checked_wcet(t));
      priority.push_back(t.priority);
    }
    group_end.assign(n, 0);
    for (size_t p = n; p-- > 0;) {
      group_end[p] = p + 1 < n && priority[p + 1] == priority[p] ? group_end[p + 1] : p + 1;
    }
    // Suffix maxima over positions >= q: N_j C_j^o (largest, where, second
    // largest) and N_j (for a uniform C^o).
    top_block.assign(n + 1, 0);
    top_where.assign(n + 1, n);
    second_block.assign(n + 1, 0);
    top_actuations.assign(n + 1, 0);
    for (size_t q = n; q-- > 0;) {
      const Nanos b = sat_mul(actuations[q], overhead[q]);
      top_block[q] = top_block[q + 1];
      top_where[q] = top_where[q + 1];
      second_block[q] = second_block[q + 1];
      if (b >= top_block[q]) {
        second_block[q] = top_block[q];
        top_block[q] = b;
        top_where[q] = q;
      } else {
        second_block[q] = std::max(second_block[q], b);
      }
      top_actuations[q] = std::max(top_actuations[q + 1], actuations[q]);
    }
  }

  Nanos blocking(size_t p) const { return top_block[group_end[p]]; }
  // B of p with position i left out.
  Nanos blocking_without(size_t p, size_t i) const {
    const size_t g = group_end[p];
    return top_where[g] == i ? second_block[g] : top_block[g];
  }
  Nanos own(size_t p) const { return sat_add(c_tee[p], blocking(p)); }
  // Is position i higher-priority interference for p?
  bool interferes(size_t i, size_t p) const { return i != p && i < group_end[p]; }

  // Least fixed point of p's recurrence with own term `own`, iterating from
  // `start` (REQUIRES: start is at most that fixed point; a larger one still
  // yields a valid witness, just not the least).
  Fix fixpoint(size_t p, Nanos own_term, Nanos start) const {
    const Nanos d = deadline[p];
    Nanos r = std::max(start, own_term);
    if (r > d) return {r, false, r, 0};
    const size_t end = group_end[p];
    while (true) {
      Nanos w = own_term;
      Nanos next = d;
      for (size_t q = 0; q < end; ++q) {
        if (q == p) continue;
        const Nanos jobs = ceil_div(r, period[q]);
        w = sat_add(w, sat_mul(jobs, c_tee[q]));
        next = std::min(next, jobs * period[q]);
      }
      if (w > d) return {w, false, w, 0};
      if (w <= r) return {r, true, w, next};
      r = w;
    }
  }

  // Walks p's intervals from the one holding `from` (> 0) to D_p in order:
  // visit(b) for each right end b (false stops the walk), then release(q)
  // for each higher-priority task q (other than `skip`) released at b,
  // whose job count ceil(t/T_q) grows by one beyond b. The caller's sums
  // start at the job counts ceil(from/T_q).
  template <typename Release, typename Visit>
  void walk(size_t p, Nanos from, size_t skip, Release release, Visit visit) {
    const Nanos d = deadline[p];
    heap_.clear();
    for (size_t q = 0; q < group_end[p]; ++q) {
      if (q == p || q == skip) continue;
      const Nanos r = ceil_div(from, period[q]) * period[q];
      if (r < d) heap_.push_back({r, q});
    }
    const auto later = [](const Release_& x, const Release_& y) { return x.at > y.at; };
    std::make_heap(heap_.begin(), heap_.end(), later);
    while (true) {
      const Nanos b = heap_.empty() ? d : std::min(heap_.front().at, d);
      if (!visit(b) || b >= d) return;
      while (!heap_.empty() && heap_.front().at == b) {
        std::pop_heap(heap_.begin(), heap_.end(), later);
        Release_& x = heap_.back();
        release(x.task);
        x.at += period[x.task];
        if (x.at < d) {
          std::push_heap(heap_.begin(), heap_.end(), later);
        } else {
          heap_.pop_back();
        }
      }
    }
  }

  size_t n;
  std::vector<size_t> order;
  std::vector<Nanos> wcet, period, deadline, overhead, c_tee;
  std::vector<int64_t> actuations, priority;
  std::vector<size_t> group_end;
  std::vector<Nanos> top_block, second_block;
  std::vector<size_t> top_where;
  std::vector<int64_t> top_actuations;

 private:
  struct Release_ {
    Nanos at;
    size_t task;
  };
  std::vector<Release_> heap_;
};

// Largest uniform C^o at which position p meets its deadline: over an
// interval ending at b, W = a + x c, so x <= (b - a) / c.
Nanos max_uniform_overhead(Model& m, size_t p, bool any_checks) {
  // R at C^o = 0: the recurrence with C^TEE = C.
  Nanos r = m.wcet[p];
  const Nanos d = m.deadline[p];
  while (true) {
    if (r > d) return kInfeasible;
    Nanos w = m.wcet[p];
    for (size_t q = 0; q < m.group_end[p]; ++q) {
      if (q != p) w = sat_add(w, sat_mul(ceil_div(r, m.period[q]), m.wcet[q]));
    }
    if (w > d) return kInfeasible;
    if (w <= r) break;
    r = w;
  }
  if (!any_checks) return kUnbounded;  // then c is 0 everywhere
  // c >= 1 from here: every other task is above p (a job at least) or below.
  Nanos a = m.wcet[p];
  Nanos c = sat_add(m.actuations[p], m.top_actuations[m.group_end[p]]);
  for (size_t q = 0; q < m.group_end[p]; ++q) {
    if (q == p) continue;
    const Nanos jobs = ceil_div(r, m.period[q]);
    a = sat_add(a, sat_mul(jobs, m.wcet[q]));
    c = sat_add(c, sat_mul(jobs, m.actuations[q]));
  }
  Nanos best = 0;  // feasible at 0
  m.walk(
      p, r, m.n, [&](size_t q) { a = sat_add(a, m.wcet[q]), c = sat_add(c, m.actuations[q]); },
      [&](Nanos b) {
        if (a > d || (d - a) / c <= best) return false;  // no later interval does better
        if (b >= a) best = std::max(best, (b - a) / c);
        return true;
      });
  return best;
}

// --- the smallest period of position i ------------------------------------

// Over an interval of p's demand ending at b on which the tasks other than i
// demand `other`, T_i passes iff for some m jobs of i, m C_i + other <= b and
// T_i >= (m C_i + other) / m; the most jobs that fit is best.
Nanos period_for_interval(Nanos b, Nanos other, Nanos c) {
  if (b - other < c) return kUnbounded;
  const Nanos k = (b - other) / c;
  return ceil_div(sat_add(sat_mul(k, c), other), k);
}

// Exact smallest T_i keeping p (below i, or beside it) schedulable.
Nanos min_period_of(Model& m, size_t i, size_t p, const Fix& f) {
  const Nanos c = m.c_tee[i];
  const Nanos d = m.deadline[p];
  Nanos other = m.own(p);
  for (size_t q = 0; q < m.group_end[p]; ++q) {
    if (q != p && q != i) other = sat_add(other, sat_mul(ceil_div(f.t, m.period[q]), m.c_tee[q]));
  }
  Nanos best = kUnbounded;
  m.walk(
      p, f.t, i, [&](size_t q) { other = sat_add(other, m.c_tee[q]); },
      [&](Nanos b) {
        if (other > d || d - other < c) return false;
        // No later interval does better than the most jobs fitting before D.
        const Nanos k = (d - other) / c;
        if (ceil_div(sat_add(sat_mul(k, c), other), k) >= best) return false;
        best = std::min(best, period_for_interval(b, other, c));
        return true;
      });
  return best;
}

Nanos min_period(Model& m, size_t i, const std::vector<Fix>& base) {
  const Nanos original = m.period[i];
  const bool implicit = m.deadline[i] == original;
  // Task i's own response does not depend on T_i; an implicit deadline
  // shrinks with it, so T_i >= R_i. The reference searches from here.
  Nanos result = implicit ? std::max<Nanos>(1, m.c_tee[i]) : m.deadline[i];
  result = std::min(result, original);
  if (implicit) result = std::max(result, base[i].t);
  // Each affected task's R gives a period at which it still passes (its
  // interval, as far as the next scheduling point): an upper bound of its
  // smallest. Only tasks whose bound exceeds the answer so far are walked.
  std::vector<std::pair<Nanos, size_t>> bounds;
  for (size_t p = 0; p < m.n; ++p) {
    if (!m.interferes(i, p)) continue;
    const Fix& f = base[p];
    const Nanos other = f.demand - ceil_div(f.t, original) * m.c_tee[i];
    bounds.push_back({std::min(original, period_for_interval(f.next, other, m.c_tee[i])), p});
  }
  std::sort(bounds.begin(), bounds.end(), std::greater<>());
  for (const auto& [bound, p] : bounds) {
    if (bound <= result) break;
    result = std::max(result, min_period_of(m, i, p, base[p]));
  }
  return result;
}

// --- the largest number of checked commands of position i ----------------

// Exact largest N_i keeping p schedulable, from its fixed point f at the
// current N_i (`now`).
int64_t max_actuations_of(Model& m, size_t i, size_t p, const Fix& f, int64_t now) {
  const Nanos o = m.overhead[i];
  const Nanos d = m.deadline[p];
  Nanos demand = m.own(p);
  for (size_t q = 0; q < m.group_end[p]; ++q) {
    if (q != p) demand = sat_add(demand, sat_mul(ceil_div(f.t, m.period[q]), m.c_tee[q]));
  }
  const bool above = m.interferes(i, p);
  const bool below = p != i && !above;  // i blocks p
  const Nanos others_block = below ? m.blocking_without(p, i) : 0;
  const Nanos block_now = below ? std::max(others_block, sat_mul(now, o)) : 0;
  Nanos jobs = above ? ceil_div(f.t, m.period[i]) : 1;
  // N_i at most this over an interval ending at b (demand as of now there).
  auto allows = [&](Nanos b) -> int64_t {
    if (!below) return now + (b - demand) / sat_mul(jobs, o);
    const Nanos rest = demand - block_now;  // without blocking
    if (sat_add(rest, others_block) > b) return -1;
    return (b - rest) / o;
  };
  int64_t best = now;
  m.walk(
      p, f.t, m.n,
      [&](size_t q) {
        demand = sat_add(demand, m.c_tee[q]);
        if (q == i) ++jobs;
      },
      [&](Nanos b) {
        if (demand > d || allows(d) <= best) return false;
        if (b >= demand - (below ? block_now - others_block : 0)) best = std::max(best, allows(b));
        return true;
      });
  return best;
}

// The largest N_i at which p's fixed point f still witnesses (over its
// interval): a lower bound of p's largest.
int64_t actuations_bound(const Model& m, size_t i, size_t p, const Fix& f, int64_t now) {
  const Nanos o = m.overhead[i];
  const Nanos slack = f.next - f.demand;
  if (p == i) return now + slack / o;
  if (m.interferes(i, p)) return now + slack / sat_mul(ceil_div(f.t, m.period[i]), o);
  const Nanos block = std::max(m.blocking_without(p, i), sat_mul(now, o));
  return sat_add(slack, block) / o;
}

int64_t max_actuations(Model& m, size_t i, const std::vector<Fix>& base) {
  const int64_t now = m.actuations[i];
  std::vector<std::pair<int64_t, size_t>> bounds;
  for (size_t p = 0; p < m.n; ++p) bounds.push_back({actuations_bound(m, i, p, base[p], now), p});
  std::sort(bounds.begin(), bounds.end());
  int64_t result = kUnbounded;
  for (const auto& [bound, p] : bounds) {
    if (bound >= result) break;
    result = std::min(result, max_actuations_of(m, i, p, base[p], now));
  }
  return result;
}

}  // namespace

Sensitivity sensitivity(const TaskSet& set) {
  Model m(set);
  const size_t n = m.n;
  Sensitivity out;
  out.tasks.resize(n);
  const bool any_checks = std::any_of(set.tasks.begin(), set.tasks.end(),
                                      [](const Task& t) { return t.actuations > 0; });
  out.max_overhead = kUnbounded;
  for (size_t p = 0; p < n; ++p) {
    const Nanos x = max_uniform_overhead(m, p, any_checks);
    out.tasks[m.order[p]].max_overhead = x;
    out.max_overhead = std::min(out.max_overhead, x);
  }

  std::vector<Fix> base(n);
  bool feasible = true;
  for (size_t p = 0; p < n && feasible; ++p) {
    base[p] = m.fixpoint(p, m.own(p), 0);
    feasible = base[p].ok;
  }
  for (size_t p = 0; p < n; ++p) {
    TaskSensitivity& s = out.tasks[m.order[p]];
    if (!feasible) {
      s.min_period = kInfeasible;
      s.max_actuations = kInfeasible;
      continue;
    }
    s.min_period = min_period(m, p, base);
    s.max_actuations = m.overhead[p] <= 0 ? kUnbounded : max_actuations(m, p, base);
  }
  return out;
}

}  // namespace contego::sched
