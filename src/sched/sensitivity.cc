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
// by branch and bound over time: the demand at the start of a range bounds
// what any interval in it can admit, so most ranges are never split.
//
// For T_i and N_i, which bind through every task they affect, the intervals
// at each task's R and at its deadline give a cheap bound first (a value at
// which it is known to pass); a task is searched only when its bound could
// decide the figure.
#include "sched/sensitivity.h"

#include <algorithm>
#include <numeric>

#include "sched/analysis.h"

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

  // p's demand at t > 0, and what is constant with it up to its interval's end.
  struct Point {
    Nanos t = 0;
    Nanos next = 0;      // the right end of t's interval: the next scheduling point, at most D
    Nanos demand = 0;    // own + sum over hp of ceil(t/T_q) C_q^TEE
    Nanos a = 0, c = 0;  // for a uniform C^o x: the demand is a + x c
  };
  // kUniform: a and c only; otherwise demand only (the searches need one).
  template <bool kUniform = false>
  Point eval(size_t p, Nanos t) const {
    Point x;
    x.t = t;
    x.next = deadline[p];
    x.demand = own(p);
    x.a = wcet[p];
    x.c = sat_add(actuations[p], top_actuations[group_end[p]]);
    for (size_t q = 0; q < group_end[p]; ++q) {
      if (q == p) continue;
      const Nanos jobs = ceil_div(t, period[q]);
      x.next = std::min(x.next, jobs * period[q]);
      if constexpr (kUniform) {
        x.a = sat_add(x.a, sat_mul(jobs, wcet[q]));
        x.c = sat_add(x.c, sat_mul(jobs, actuations[q]));
      } else {
        x.demand = sat_add(x.demand, sat_mul(jobs, c_tee[q]));
      }
    }
    return x;
  }

  size_t n;
  std::vector<size_t> order;
  std::vector<Nanos> wcet, period, deadline, overhead, c_tee;
  std::vector<int64_t> actuations, priority;
  std::vector<size_t> group_end;
  std::vector<Nanos> top_block, second_block;
  std::vector<size_t> top_where;
  std::vector<int64_t> top_actuations;
};

// The largest value(x) over the right ends of p's intervals in [lo, hi], or
// `best` if none is larger. bound(x, hi) is at least value() of every right
// end in [x.t, hi] (the demand only grows with t).
template <bool kUniform = false, typename Value, typename Bound>
int64_t best_over(const Model& m, size_t p, Nanos lo, Nanos hi, int64_t best, const Value& value,
                  const Bound& bound) {
  if (lo > hi) return best;
  const Model::Point x = m.eval<kUniform>(p, lo);
  if (bound(x, hi) <= best) return best;
  if (x.next <= hi) best = std::max(best, value(x));
  if (x.next >= hi) return best;
  const Nanos mid = x.next + (hi - x.next) / 2;
  best = best_over<kUniform>(m, p, mid + 1, hi, best, value, bound);  // larger values lie late
  return best_over<kUniform>(m, p, x.next + 1, mid, best, value, bound);
}

// Largest uniform C^o at which position p meets its deadline: over an
// interval ending at b, W = a + x c, so x <= (b - a) / c.
Nanos max_uniform_overhead(const Model& m, size_t p, bool any_checks) {
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
  auto admits = [](Nanos b, Nanos a, Nanos c) -> int64_t { return b >= a ? (b - a) / c : -1; };
  const Model::Point at_d = m.eval<true>(p, d);
  return best_over<true>(
      m, p, r, d, std::max<int64_t>(0, admits(d, at_d.a, at_d.c)),
      [&](const Model::Point& x) { return admits(x.next, x.a, x.c); },
      [&](const Model::Point& x, Nanos hi) { return admits(hi, x.a, x.c); });
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

Model::Point point_of(const Fix& f) {
  Model::Point x;
  x.t = f.t;
  x.next = f.next;
  x.demand = f.demand;
  return x;
}

// The smallest T_i an interval of p's demand (x at its start) ending at b
// admits: the demand of the tasks other than i is constant over it.
Nanos period_admitted(const Model& m, size_t i, Nanos b, const Model::Point& x) {
  const Nanos c = m.c_tee[i];
  return period_for_interval(b, x.demand - ceil_div(x.t, m.period[i]) * c, c);
}

Nanos min_period(const Model& m, size_t i, const std::vector<Fix>& base,
                 const std::vector<Model::Point>& at_deadline) {
  const Nanos original = m.period[i];
  const bool implicit = m.deadline[i] == original;
  // Task i's own response does not depend on T_i; an implicit deadline
  // shrinks with it, so T_i >= R_i. The reference searches from here.
  Nanos result = implicit ? std::max<Nanos>(1, m.c_tee[i]) : m.deadline[i];
  result = std::min(result, original);
  if (implicit) result = std::max(result, base[i].t);
  // Periods at which each affected task is known to pass (its interval at
  // R, the one ending at its deadline): upper bounds of its smallest. The
  // largest is searched first; a task whose bound is no larger than the
  // answer so far is not searched.
  std::vector<std::pair<Nanos, size_t>> bounds;
  for (size_t p = 0; p < m.n; ++p) {
    if (!m.interferes(i, p)) continue;
    const Model::Point x = point_of(base[p]);
    bounds.push_back({std::min({original, period_admitted(m, i, x.next, x),
                                period_admitted(m, i, m.deadline[p], at_deadline[p])}),
                      p});
  }
  std::sort(bounds.begin(), bounds.end(), std::greater<>());
  for (const auto& [bound, p] : bounds) {
    if (bound <= result) break;
    // The smallest period is the largest negated one.
    const Nanos smallest = -best_over(
        m, p, base[p].t, m.deadline[p], -bound,
        [&](const Model::Point& x) { return -period_admitted(m, i, x.next, x); },
        [&](const Model::Point& x, Nanos hi) { return -period_admitted(m, i, hi, x); });
    result = std::max(result, smallest);
  }
  return result;
}

// What N_i an interval of p's demand admits.
class ActuationsOf {
 public:
  ActuationsOf(const Model& m, size_t i, size_t p)
      : m_(m), i_(i), now_(m.actuations[i]), o_(m.overhead[i]) {
    above_ = m.interferes(i, p);
    below_ = p != i && !above_;  // i blocks p
    others_block_ = below_ ? m.blocking_without(p, i) : 0;
    block_now_ = below_ ? std::max(others_block_, sat_mul(now_, o_)) : 0;
  }
  // N_i at most this over an interval ending at b, x its demand now.
  int64_t admits(Nanos b, const Model::Point& x) const {
    if (below_) {
      const Nanos rest = x.demand - block_now_;  // without blocking
      return sat_add(rest, others_block_) > b ? -1 : (b - rest) / o_;
    }
    if (b < x.demand) return -1;
    const Nanos jobs = above_ ? ceil_div(x.t, m_.period[i_]) : 1;
    return now_ + (b - x.demand) / sat_mul(jobs, o_);
  }

 private:
  const Model& m_;
  size_t i_;
  int64_t now_;
  Nanos o_;
  bool above_ = false, below_ = false;
  Nanos others_block_ = 0, block_now_ = 0;
};

int64_t max_actuations(const Model& m, size_t i, const std::vector<Fix>& base,
                       const std::vector<Model::Point>& at_deadline) {
  // Lower bounds of each task's largest N_i, from its interval at R and
  // the one ending at its deadline; the smallest is searched first, and a
  // task whose bound is already no smaller than the answer is not searched.
  std::vector<std::pair<int64_t, size_t>> bounds;
  for (size_t p = 0; p < m.n; ++p) {
    const ActuationsOf of(m, i, p);
    const Model::Point x = point_of(base[p]);
    bounds.push_back({std::max(of.admits(x.next, x), of.admits(m.deadline[p], at_deadline[p])), p});
  }
  std::sort(bounds.begin(), bounds.end());
  int64_t result = kUnbounded;
  for (const auto& [bound, p] : bounds) {
    if (bound >= result) break;
    const ActuationsOf of(m, i, p);
    result =
        std::min(result, best_over(
                             m, p, base[p].t, m.deadline[p], bound,
                             [&](const Model::Point& x) { return of.admits(x.next, x); },
                             [&](const Model::Point& x, Nanos hi) { return of.admits(hi, x); }));
  }
  return result;
}

}  // namespace

Sensitivity sensitivity(const TaskSet& set) {
  const Model m(set);
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

  std::vector<Model::Point> at_deadline(n);
  for (size_t p = 0; p < n; ++p) at_deadline[p] = m.eval(p, m.deadline[p]);
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
    s.min_period = min_period(m, p, base, at_deadline);
    s.max_actuations = m.overhead[p] <= 0 ? kUnbounded : max_actuations(m, p, base, at_deadline);
  }
  return out;
}

}  // namespace contego::sched
