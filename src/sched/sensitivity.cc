// Sensitivity by witness jumps (see sensitivity.h). Every figure equals the
// binary search of sensitivity_search.cc; sensitivity_test.cc checks it on
// thousands of random sets.
//
// The fact used throughout: a task's demand W(t) = own + sum over hp of
// ceil(t/T_h) C_h^TEE is constant between scheduling points, so the least
// fixed point R of the recurrence (W(R) <= R <= D) stays a witness of
// schedulability at every t in [R, P], P the next multiple of a
// higher-priority period (or D). Over that interval W is linear in C^o and
// in N_i and a step function of T_i, so how far the parameter can move with
// the witness intact is one division. Beyond it, only the tasks whose
// witness binds are re-analysed, starting from R (a lower bound of the new
// fixed point, since every parameter moves in the harder direction).
#include <algorithm>
#include <numeric>

#include "sched/analysis.h"
#include "sched/sensitivity.h"

namespace contego::sched {
namespace {

// Rounds of jumps before falling back to a binary search (each round moves
// past at least one scheduling point, so a task far below many short
// periods could otherwise take many).
constexpr int kMaxRounds = 64;

struct Fix {
  Nanos t = 0;       // least fixed point (or the first iterate beyond D)
  bool ok = false;   // t <= D
  Nanos demand = 0;  // W(t) <= t
  Nanos next = 0;    // the next scheduling point at or after t, at most D
};

// As Fix, for a uniform C^o = x: W(t) = a + x b over [t, next].
struct UniformFix {
  bool ok = false;
  Nanos t = 0, a = 0, b = 0, next = 0;
};

template <typename Ok>
int64_t largest_ok(int64_t lo, int64_t hi, Ok ok) {
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo + 1) / 2;
    if (ok(mid)) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  return lo;
}

template <typename Ok>
int64_t smallest_ok(int64_t lo, int64_t hi, Ok ok) {
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo) / 2;
    if (ok(mid)) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return hi;
}

Nanos ceil_div(Nanos a, Nanos b) { return (a + b - 1) / b; }

// The tasks by decreasing priority (stable, as Analyzer orders them).
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

  UniformFix uniform_fixpoint(size_t p, Nanos x, Nanos start) const {
    const Nanos d = deadline[p];
    const Nanos a0 = wcet[p];
    const Nanos b0 = sat_add(actuations[p], top_actuations[group_end[p]]);
    Nanos r = std::max(start, sat_add(a0, sat_mul(x, b0)));
    if (r > d) return {};
    const size_t end = group_end[p];
    while (true) {
      Nanos a = a0, b = b0, next = d;
      for (size_t q = 0; q < end; ++q) {
        if (q == p) continue;
        const Nanos jobs = ceil_div(r, period[q]);
        a = sat_add(a, sat_mul(jobs, wcet[q]));
        b = sat_add(b, sat_mul(jobs, actuations[q]));
        next = std::min(next, jobs * period[q]);
      }
      const Nanos w = sat_add(a, sat_mul(x, b));
      if (w > d) return {};
      if (w <= r) return {true, r, a, b, next};
      r = w;
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
};

// Largest uniform C^o at which position p meets its deadline.
Nanos max_uniform_overhead(const Model& m, size_t p, bool any_checks) {
  UniformFix f = m.uniform_fixpoint(p, 0, 0);
  if (!f.ok) return kInfeasible;
  if (!any_checks) return kUnbounded;  // then b is 0 everywhere
  Nanos x = 0;                         // verified
  for (int round = 0;; ++round) {
    x = std::max(x, (f.next - f.a) / f.b);  // b >= 1: some task has checks
    if (round == kMaxRounds) {
      const Nanos from = f.t;
      return largest_ok(x, m.deadline[p],
                        [&](Nanos c) { return m.uniform_fixpoint(p, c, from).ok; });
    }
    const UniformFix g = m.uniform_fixpoint(p, x + 1, f.next);
    if (!g.ok) return x;
    f = g;
  }
}

// A task's witness while one parameter of position i moves.
struct Witness {
  Fix fix;
  int64_t at = 0;     // the parameter's value when fix was computed
  int64_t bound = 0;  // how far the parameter may go with fix still a witness
};

// The smallest T_i with the fixed point f of p (computed at T_i = at) still
// a witness: over [f.t, f.next] p's demand is `other` + ceil(t/T_i) C_i^TEE.
Nanos period_bound(const Model& m, size_t i, const Fix& f, Nanos at) {
  const Nanos c = m.c_tee[i];
  const Nanos other = f.demand - ceil_div(f.t, at) * c;
  Nanos best = at;
  for (const Nanos t : {f.t, f.next}) {
    if (t - other < c) continue;
    best = std::min(best, ceil_div(t, (t - other) / c));
  }
  return best;
}

Nanos min_period(Model& m, size_t i, const std::vector<Fix>& base) {
  const Nanos original = m.period[i];
  const bool implicit = m.deadline[i] == original;
  // Task i's own response does not depend on T_i; an implicit deadline
  // shrinks with it, so T_i >= R_i. The reference searches from here.
  Nanos floor = implicit ? std::max<Nanos>(1, m.c_tee[i]) : m.deadline[i];
  floor = std::min(floor, original);
  if (implicit) floor = std::max(floor, base[i].t);
  std::vector<std::pair<size_t, Witness>> affected;
  for (size_t j = 0; j < m.n; ++j) {
    if (!m.interferes(i, j)) continue;
    affected.push_back({j, {base[j], original, period_bound(m, i, base[j], original)}});
  }
  auto candidate = [&] {
    Nanos t = floor;
    for (const auto& [j, w] : affected) t = std::max(t, w.bound);
    return t;
  };
  Nanos t = candidate();  // verified: every witness holds there
  for (int round = 0; t > floor; ++round) {
    if (round == kMaxRounds) {
      auto ok = [&](Nanos x) {
        m.period[i] = x;
        bool all = true;
        for (const auto& [j, w] : affected) {
          all = all && m.fixpoint(j, m.own(j), w.fix.t).ok;
          if (!all) break;
        }
        m.period[i] = original;
        return all;
      };
      return smallest_ok(floor, t, ok);
    }
    m.period[i] = t - 1;
    bool ok = true;
    for (auto& [j, w] : affected) {
      if (w.bound < t) continue;  // still a witness at t - 1
      const Fix g = m.fixpoint(j, m.own(j), w.fix.t);
      if (!g.ok) {
        ok = false;
        break;
      }
      w = {g, t - 1, period_bound(m, i, g, t - 1)};
    }
    m.period[i] = original;
    if (!ok) return t;
    t = candidate();
  }
  return t;
}

// The largest N_i with the fixed point f of p (computed at N_i = at) still a
// witness over [f.t, f.next].
int64_t actuations_bound(const Model& m, size_t i, size_t p, const Fix& f, int64_t at) {
  const Nanos o = m.overhead[i];
  const Nanos slack = f.next - f.demand;
  if (p == i) return at + slack / o;
  if (m.interferes(i, p)) return at + slack / sat_mul(ceil_div(f.t, m.period[i]), o);
  // i is below p: it enters p's demand through max(B without i, N_i C_i^o).
  const Nanos block = std::max(m.blocking_without(p, i), sat_mul(at, o));
  return sat_add(slack, block) / o;
}

// p's own term with N_i = k.
Nanos own_with(const Model& m, size_t i, size_t p, int64_t k) {
  if (p == i || m.interferes(i, p)) return m.own(p);  // c_tee[i] is set by the caller
  return sat_add(m.c_tee[p], std::max(m.blocking_without(p, i), sat_mul(k, m.overhead[i])));
}

int64_t max_actuations(Model& m, size_t i, const std::vector<Fix>& base) {
  const int64_t original = m.actuations[i];
  const Nanos original_c_tee = m.c_tee[i];
  const Nanos o = m.overhead[i];
  std::vector<Witness> w(m.n);
  for (size_t j = 0; j < m.n; ++j) w[j] = {base[j], original, actuations_bound(m, i, j, base[j], original)};
  auto candidate = [&] {
    int64_t k = kUnbounded;
    for (const Witness& x : w) k = std::min(k, x.bound);
    return k;
  };
  auto set_n = [&](int64_t k) { m.c_tee[i] = sat_add(m.wcet[i], sat_mul(k, o)); };
  int64_t k = candidate();  // verified
  for (int round = 0;; ++round) {
    if (round == kMaxRounds) {
      const int64_t top = m.deadline[i] / o + 1;  // C^TEE > D beyond
      auto ok = [&](int64_t x) {
        set_n(x);
        bool all = true;
        for (size_t j = 0; j < m.n && all; ++j) {
          all = m.fixpoint(j, own_with(m, i, j, x), w[j].fix.t).ok;
        }
        m.c_tee[i] = original_c_tee;
        return all;
      };
      return largest_ok(k, std::max(top, k), ok);
    }
    set_n(k + 1);
    bool ok = true;
    for (size_t j = 0; j < m.n; ++j) {
      if (w[j].bound > k) continue;
      const Fix g = m.fixpoint(j, own_with(m, i, j, k + 1), w[j].fix.t);
      if (!g.ok) {
        ok = false;
        break;
      }
      w[j] = {g, k + 1, actuations_bound(m, i, j, g, k + 1)};
    }
    m.c_tee[i] = original_c_tee;
    if (!ok) return k;
    k = candidate();
  }
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
