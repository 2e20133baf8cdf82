// Sensitivity by scheduling points (see sensitivity.h). Every figure equals
// the binary search of sensitivity_search.cc; sensitivity_test.cc checks it
// on thousands of random sets.
//
// The fact used throughout: task p's demand W(t) = own + sum over hp of
// ceil(t/T_h) C_h^TEE is constant on the intervals between scheduling
// points (multiples of higher-priority periods, and D_p), so p meets its
// deadline iff W(b) <= b at the right end b of some interval up to D_p,
// and W(t) > t everywhere before its response time R.
//
// Two searches find the figures, both exact:
//
// - The response-time iteration itself, for a figure that is one value per
//   task (the uniform C^o it tolerates; its largest slack b - W(b), which
//   answers N_i for i itself and for the tasks i blocks, where N_i adds a
//   constant). Given a value v that p is known to admit (the interval
//   ending at D gives one, usually close), iterate p's demand at v + 1 to
//   its least fixed point r, starting below it. If the iterate passes D, v
//   is the figure; otherwise r's interval admits more than v, read off in
//   one division, and the iteration goes on from r. The iterates only
//   grow, so the demand is kept up to date by a Sweep that counts releases
//   by comparison instead of dividing.
//
// - For T_i and N_i of a task above p, which differ for every pair (i, p):
//   a branch and bound over p's intervals in [R, D] (IntervalTree). The
//   tree of ranges depends on p alone, so it is built once, lazily, and
//   every pair searching p reuses the demands already evaluated. The
//   intervals at each task's R and D bound its figure first; a task is
//   searched only while that bound could decide the figure.
#include "sched/sensitivity.h"

#include <algorithm>
#include <array>
#include <numeric>

#include "sched/analysis.h"

namespace contego::sched {
namespace {

Nanos ceil_div(Nanos a, Nanos b) { return (a + b - 1) / b; }

constexpr size_t kNoTask = static_cast<size_t>(-1);

class Model {
 public:
  explicit Model(const TaskSet& set) : n(set.tasks.size()) {
    order.resize(n);
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return set.tasks[a].priority > set.tasks[b].priority;
    });
    for (auto* v : {&wcet, &period, &deadline, &actuations, &overhead, &c_tee, &priority}) {
      v->reserve(n);
    }
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
    group_start.assign(n, 0);
    for (size_t p = 1; p < n; ++p) {
      group_start[p] = priority[p - 1] == priority[p] ? group_start[p - 1] : p;
    }
    group_end.assign(n, 0);
    for (size_t p = n; p-- > 0;) {
      group_end[p] = p + 1 < n && priority[p + 1] == priority[p] ? group_end[p + 1] : p + 1;
    }
    // Suffix maxima over positions >= q: N_j C_j^o (largest, where, second
    // largest) and N_j (the blocking per unit of a uniform C^o).
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

  size_t n;
  std::vector<size_t> order;
  std::vector<Nanos> wcet, period, deadline, overhead, c_tee;
  std::vector<int64_t> actuations, priority;
  std::vector<size_t> group_start, group_end;
  std::vector<Nanos> top_block, second_block;
  std::vector<size_t> top_where;
  std::vector<int64_t> top_actuations;
};

// The demand on task p of the tasks that interfere with it (but one, when
// asked), kept up to date while t only grows, as it does in every iteration
// here: a task's job count changes only when t passes its next release,
// found by one comparison, so a step divides only when t jumps more than
// one period of a task. The sums are per-job weights times job counts (C^TEE;
// or C and N for a uniform C^o).
//
// No sum needs to be exact beyond kMaxDuration (every deadline is below,
// so a larger demand fails either way): weights are capped just above it,
// and so are the sums after every kBlock tasks, which keeps the common step
// free of overflow checks (it adds at most one weight per task).
template <size_t kSums>
class Sweep {
 public:
  using Weights = std::array<const std::vector<Nanos>*, kSums>;
  static constexpr Nanos kCap = kMaxDuration + 1;
  static constexpr size_t kBlock = 4096;  // kBlock * kCap fits in int64 with room

  // Starts at t > 0 over p's interferers but `skip`.
  void start(const Model& m, size_t p, size_t skip, const Weights& weights, Nanos t) {
    period_.clear();
    release_.clear();
    for (auto& w : weight_) w.clear();
    for (size_t q = 0; q < m.group_end[p]; ++q) {
      if (q == p || q == skip) continue;
      period_.push_back(m.period[q]);
      for (size_t k = 0; k < kSums; ++k) weight_[k].push_back(std::min((*weights[k])[q], kCap));
      release_.push_back(0);
    }
    sums_.fill(0);
    deadline_ = m.deadline[p];
    advance(t);
  }

  // REQUIRES: t > 0 and at least the last t.
  void advance(Nanos t) {
    Nanos next = deadline_;
    std::array<Nanos, kSums> sums = sums_;
    for (size_t block = 0; block < period_.size(); block += kBlock) {
      const size_t end = std::min(period_.size(), block + kBlock);
      for (size_t q = block; q < end; ++q) {
        const Nanos behind = t - release_[q];
        if (behind > period_[q]) [[unlikely]] {
          catch_up(q, t, sums);
        } else {
          const Nanos released = behind > 0 ? -1 : 0;  // all ones: one more job
          release_[q] += period_[q] & released;
          for (size_t k = 0; k < kSums; ++k) sums[k] += weight_[k][q] & released;
        }
        next = std::min(next, release_[q]);
      }
      for (size_t k = 0; k < kSums; ++k) sums[k] = std::min(sums[k], kCap);
    }
    sums_ = sums;
    next_ = next;
  }

  Nanos sum(size_t k = 0) const { return sums_[k]; }
  // The right end of t's interval: the next release at or after t, at most D_p.
  Nanos next() const { return next_; }

 private:
  // Counts the jobs of task q up to t by division: t passed several releases.
  void catch_up(size_t q, Nanos t, std::array<Nanos, kSums>& sums) {
    const Nanos more = ceil_div(t, period_[q]) - release_[q] / period_[q];
    release_[q] += more * period_[q];
    for (size_t k = 0; k < kSums; ++k) {
      sums[k] = std::min(sat_add(sums[k], sat_mul(more, weight_[k][q])), kCap);
    }
  }

  std::vector<Nanos> period_;
  std::array<std::vector<Nanos>, kSums> weight_;
  std::vector<Nanos> release_;  // the first release at or after t: ceil(t / period) * period
  std::array<Nanos, kSums> sums_{};
  Nanos deadline_ = 0;
  Nanos next_ = 0;
};

// What the analysis at the original parameters knows about position p: its
// response time R, the right end of R's interval, and the demand at D.
struct Base {
  Nanos response = 0;  // W(R) = R
  Nanos next = 0;
  Nanos demand_at_deadline = 0;
  bool ok = false;
};

Base base_of(const Model& m, size_t p, Sweep<1>& sweep) {
  Base b;
  const Nanos own = m.own(p);
  const Nanos d = m.deadline[p];
  Nanos r = own;
  if (r > d) return b;
  for (sweep.start(m, p, kNoTask, {&m.c_tee}, r);; sweep.advance(r)) {
    const Nanos w = sat_add(own, sweep.sum());
    if (w > d) return b;
    if (w <= r) break;
    r = w;
  }
  b.response = r;
  b.next = sweep.next();
  b.ok = true;
  sweep.advance(d);
  b.demand_at_deadline = sat_add(own, sweep.sum());
  return b;
}

// The largest x = (b - a) / c over the right ends b of p's intervals in
// [lo, hi], or `best` if none is larger: a branch and bound over time
// like IntervalTree's (the demand at a range's start bounds what any
// interval in it admits), for max_uniform_overhead when its iteration
// would crawl (see there). c counts the commands per unit of C^o.
Nanos best_uniform_over(const Model& m, size_t p, Nanos lo, Nanos hi, Nanos best,
                        Nanos own_commands) {
  if (lo > hi) return best;
  Nanos a = m.wcet[p], c = own_commands, next = m.deadline[p];
  for (size_t q = 0; q < m.group_end[p]; ++q) {
    if (q == p) continue;
    const Nanos jobs = ceil_div(lo, m.period[q]);
    a = sat_add(a, sat_mul(jobs, m.wcet[q]));
    c = sat_add(c, sat_mul(jobs, m.actuations[q]));
    next = std::min(next, jobs * m.period[q]);
  }
  auto admits = [&](Nanos b) { return b >= a ? (b - a) / c : Nanos{-1}; };
  if (admits(hi) <= best) return best;
  if (next <= hi) best = std::max(best, admits(next));
  if (next >= hi) return best;
  const Nanos mid = next + (hi - next) / 2;
  best = best_uniform_over(m, p, mid + 1, hi, best, own_commands);  // larger values lie late
  return best_uniform_over(m, p, next + 1, mid, best, own_commands);
}

// Largest uniform C^o at which position p meets its deadline: over an
// interval ending at b, W = a + x c, so x <= (b - a) / c.
// `base`: p's response at the original overheads, a start for every C^o
// at least `largest_overhead` (the demand is no smaller there).
Nanos max_uniform_overhead(const Model& m, size_t p, bool any_checks, const Base& base,
                           Nanos largest_overhead, Sweep<2>& sweep) {
  const Nanos d = m.deadline[p];
  // Per unit of C^o: p's own commands and the most commands below it.
  const Nanos own_commands = sat_add(m.actuations[p], m.top_actuations[m.group_end[p]]);
  Nanos best = kInfeasible;  // the largest C^o known to pass
  // With any checked command, c >= 1: every other task is above p (a job
  // at least) or below it. The interval ending at D gives a start.
  sweep.start(m, p, kNoTask, {&m.wcet, &m.actuations}, d);
  const Nanos a_at_d = sat_add(m.wcet[p], sweep.sum(0));
  if (any_checks && a_at_d <= d) best = (d - a_at_d) / sat_add(own_commands, sweep.sum(1));
  Nanos r = m.wcet[p];  // at most the least fixed point at any C^o
  if (r > d) return kInfeasible;
  if (base.ok && best + 1 >= largest_overhead) r = base.response;
  sweep.start(m, p, kNoTask, {&m.wcet, &m.actuations}, r);
  // Each fixed point moves past at least one interval and raises the
  // figure by at least 1. When the best interval lies far from D among
  // very many (a deadline of days beside a period of milliseconds), that
  // can mean millions of fixed points: after kFixedPoints, the rest of
  // [R, D] is left to a branch and bound.
  constexpr int kFixedPoints = 64;
  int fixed_points = 0;
  while (true) {
    const Nanos a = sat_add(m.wcet[p], sweep.sum(0));
    const Nanos c = sat_add(own_commands, sweep.sum(1));
    const Nanos w = sat_add(a, sat_mul(best + 1, c));
    if (w > d) return best;
    if (w > r) {
      r = w;
      sweep.advance(r);
      continue;
    }
    // p passes at best + 1; with no checked command anywhere, c is 0 and
    // C^o cannot matter.
    if (!any_checks) return kUnbounded;
    best = (sweep.next() - a) / c;  // what r's interval admits
    if (++fixed_points == kFixedPoints) {
      return best_uniform_over(m, p, sweep.next() + 1, d, best, own_commands);
    }
  }
}

// --- the searches of T_i and N_i over a task's intervals ------------------

// p's demand over [R, D] as a lazily built tree of time ranges, shared by
// every search of a T_i or N_i over p (they visit mostly the same ranges,
// so a range is evaluated once for all of them). A node is a range
// [lo, hi] with p's demand at lo and the end of lo's interval; its children
// split the rest of the range, after that interval, in two. A search walks
// it as a branch and bound: the demand at lo bounds what any interval in
// the range admits (the demand only grows with t), so most ranges are
// never split.
class IntervalTree {
 public:
  struct Range {
    Nanos lo = 0, hi = 0;
    Nanos demand = 0;  // p's demand W(lo)
    Nanos next = 0;    // the right end of lo's interval: the next scheduling point, at most D
  };

  IntervalTree(const Model& m, const std::vector<Base>& base)
      : m_(m), base_(base), root_(m.n, kNone) {
    nodes_.reserve(8 * m.n);  // about what the bench's sets use
  }

  // The largest value(x) over the interval ends x.next of p's intervals in
  // [R, D], or `best` if none is larger; some value at least `enough`
  // once one is found. bound(x) is at least value() of every interval end
  // in x's range.
  template <typename Value, typename Bound>
  int64_t best_over(size_t p, int64_t best, int64_t enough, const Value& value,
                    const Bound& bound) {
    if (root_[p] == kNone) {
      root_[p] = static_cast<int32_t>(nodes_.size());
      nodes_.push_back({{base_[p].response, m_.deadline[p], base_[p].response, base_[p].next}});
    }
    return visit(p, root_[p], best, enough, value, bound);
  }

 private:
  static constexpr int32_t kNone = -1;
  struct Node {
    Range range;
    int32_t right = kNone, left = kNone;  // [mid + 1, hi], [next + 1, mid]
  };

  template <typename Value, typename Bound>
  int64_t visit(size_t p, int32_t node, int64_t best, int64_t enough, const Value& value,
                const Bound& bound) {
    const Range x = nodes_[node].range;
    if (bound(x) <= best) return best;
    if (x.next <= x.hi) best = std::max(best, value(x));
    if (x.next >= x.hi || best >= enough) return best;
    const Nanos mid = x.next + (x.hi - x.next) / 2;
    // Larger values lie late: the right half first.
    if (nodes_[node].right == kNone) nodes_[node].right = make(p, mid + 1, x.hi);
    best = visit(p, nodes_[node].right, best, enough, value, bound);
    if (x.next + 1 > mid || best >= enough) return best;
    if (nodes_[node].left == kNone) nodes_[node].left = make(p, x.next + 1, mid);
    return visit(p, nodes_[node].left, best, enough, value, bound);
  }

  // A node for [lo, hi], with p's demand at lo evaluated from scratch.
  int32_t make(size_t p, Nanos lo, Nanos hi) {
    Range x{lo, hi, m_.own(p), m_.deadline[p]};
    for (size_t q = 0; q < m_.group_end[p]; ++q) {
      if (q == p) continue;
      const Nanos jobs = ceil_div(lo, m_.period[q]);
      x.demand = sat_add(x.demand, sat_mul(jobs, m_.c_tee[q]));
      x.next = std::min(x.next, jobs * m_.period[q]);
    }
    nodes_.push_back({x});
    return static_cast<int32_t>(nodes_.size() - 1);
  }

  const Model& m_;
  const std::vector<Base>& base_;
  std::vector<Node> nodes_;
  std::vector<int32_t> root_;  // by position; kNone until first searched
};

// The largest slack b - W(b) over p's intervals up to D: how much constant
// demand p can still take (N_i of p itself, or of a task that blocks it).
Nanos largest_slack_of(const Model& m, size_t p, const Base& base, Sweep<1>& sweep) {
  const Nanos own = m.own(p);
  const Nanos d = m.deadline[p];
  Nanos best = std::max(base.next - base.response, d - base.demand_at_deadline);
  Nanos r = base.response;
  sweep.start(m, p, kNoTask, {&m.c_tee}, r);
  while (true) {
    const Nanos w = sat_add(own, sweep.sum());
    const Nanos shifted = sat_add(w, best + 1);
    if (shifted > d) return best;
    if (shifted > r) {
      r = shifted;
      sweep.advance(r);
      continue;
    }
    best = sweep.next() - w;  // r's interval has more
  }
}

// What the searches for T_i and N_i share: the analysis at the original
// parameters, each task's largest slack once asked for, the interval trees
// and scratch space.
struct Shared {
  const Model& m;
  std::vector<Base> base;
  std::vector<Nanos> slack;  // kUnknown until asked for
  std::vector<Nanos> bounds;
  Sweep<1> sweep;
  IntervalTree tree;
  static constexpr Nanos kUnknown = -1;

  explicit Shared(const Model& model)
      : m(model), base(model.n), slack(model.n, kUnknown), tree(model, base) {
    for (size_t p = 0; p < m.n; ++p) base[p] = base_of(m, p, sweep);
  }
  bool feasible() const {
    return std::all_of(base.begin(), base.end(), [](const Base& b) { return b.ok; });
  }
  Nanos largest_slack(size_t p) {
    if (slack[p] == kUnknown) slack[p] = largest_slack_of(m, p, base[p], sweep);
    return slack[p];
  }
};

// How N_i enters p's demand: through C_i^TEE as interference (i above p),
// as p's own cost (p = i), or through the blocking (i below p).
class ActuationsOf {
 public:
  ActuationsOf(const Model& m, size_t i, size_t p)
      : period_(m.period[i]), now_(m.actuations[i]), o_(m.overhead[i]) {
    above_ = m.interferes(i, p);
    below_ = p != i && !above_;
    others_block_ = below_ ? m.blocking_without(p, i) : 0;
    block_now_ = below_ ? std::max(others_block_, sat_mul(now_, o_)) : 0;
  }
  // The largest N_i p admits, when N_i adds a constant (i is not above p):
  // what its interval of largest slack admits.
  int64_t admits_with_slack(Nanos slack) const {
    return below_ ? sat_add(slack, block_now_) / o_ : now_ + slack / o_;
  }
  // The largest N_i an interval ending at b admits, given p's demand w over
  // it at the original N_i and a point t in it.
  int64_t admits(Nanos b, Nanos t, Nanos w) const {
    if (below_) {
      const Nanos rest = w - block_now_;  // without blocking
      return sat_add(rest, others_block_) > b ? -1 : (b - rest) / o_;
    }
    if (b < w) return -1;
    return now_ + (b - w) / sat_mul(jobs(t), o_);
  }

 private:
  Nanos jobs(Nanos t) const { return above_ ? ceil_div(t, period_) : 1; }
  Nanos period_;
  int64_t now_;
  Nanos o_;
  bool above_ = false, below_ = false;
  Nanos others_block_ = 0, block_now_ = 0;
};

// --- the smallest period of position i ------------------------------------

// Over an interval of p's demand ending at b on which the tasks other than i
// demand `other`, T_i passes iff for some m jobs of i, m C_i + other <= b and
// T_i >= (m C_i + other) / m; the most jobs that fit is best.
Nanos period_for_interval(Nanos b, Nanos other, Nanos c) {
  if (b - other < c) return kUnbounded;
  const Nanos k = (b - other) / c;
  return ceil_div(sat_add(sat_mul(k, c), other), k);
}

// The smallest T_i an interval of p's demand, ending at b, admits; `demand`
// is p's demand over it, `t` a point in it.
Nanos period_admitted(const Model& m, size_t i, Nanos b, Nanos t, Nanos demand) {
  const Nanos c = m.c_tee[i];
  return period_for_interval(b, demand - ceil_div(t, m.period[i]) * c, c);
}

Nanos min_period(size_t i, Shared& shared) {
  const Model& m = shared.m;
  const std::vector<Base>& base = shared.base;
  std::vector<Nanos>& bounds = shared.bounds;
  const Nanos original = m.period[i];
  const bool implicit = m.deadline[i] == original;
  // Task i's own response does not depend on T_i; an implicit deadline
  // shrinks with it, so T_i >= R_i. The reference searches from here.
  Nanos result = implicit ? std::max<Nanos>(1, m.c_tee[i]) : m.deadline[i];
  result = std::min(result, original);
  if (implicit) result = std::max(result, base[i].response);
  // The figure is the largest of the smallest periods the tasks below i
  // admit. The intervals at R and at D give each a period at which it is
  // known to pass; the largest is searched first, then only the tasks whose
  // bound is still larger than the answer.
  bounds.assign(m.n, 0);
  size_t first = kNoTask;
  for (size_t p = m.group_start[i]; p < m.n; ++p) {
    if (!m.interferes(i, p)) continue;
    const Base& b = base[p];
    bounds[p] =
        std::min({original, period_admitted(m, i, b.next, b.response, b.response),
                  period_admitted(m, i, m.deadline[p], m.deadline[p], b.demand_at_deadline)});
    if (first == kNoTask || bounds[p] > bounds[first]) first = p;
  }
  if (first == kNoTask) return result;
  auto search = [&](size_t p) {
    if (bounds[p] <= result) return;
    // The smallest period is the largest negated one.
    const Nanos smallest = -shared.tree.best_over(
        p, -bounds[p], -result,
        [&](const IntervalTree::Range& x) {
          return -period_admitted(m, i, x.next, x.lo, x.demand);
        },
        [&](const IntervalTree::Range& x) { return -period_admitted(m, i, x.hi, x.lo, x.demand); });
    result = std::max(result, smallest);
  };
  search(first);
  for (size_t p = m.group_start[i]; p < m.n; ++p) {
    if (p != first && m.interferes(i, p)) search(p);
  }
  return result;
}

// --- the largest number of checked commands of position i ------------------

int64_t max_actuations(size_t i, Shared& shared) {
  // The figure is the least of the largest N_i each task admits. The
  // intervals at R and at D give each a value it is known to admit; the
  // least is searched first, then only the tasks whose bound is still
  // below the answer. For i itself and the tasks i blocks, N_i adds a
  // constant, so their largest slack (computed once for every i) answers.
  const Model& m = shared.m;
  const std::vector<Base>& base = shared.base;
  std::vector<Nanos>& bounds = shared.bounds;
  bounds.assign(m.n, 0);
  size_t first = 0;
  for (size_t p = 0; p < m.n; ++p) {
    const ActuationsOf of(m, i, p);
    bounds[p] = std::max(of.admits(base[p].next, base[p].response, base[p].response),
                         of.admits(m.deadline[p], m.deadline[p], base[p].demand_at_deadline));
    if (bounds[p] < bounds[first]) first = p;
  }
  int64_t result = kUnbounded;
  auto search = [&](size_t p) {
    if (bounds[p] >= result) return;
    const ActuationsOf of(m, i, p);
    if (m.interferes(i, p)) {
      result = std::min(
          result,
          shared.tree.best_over(
              p, bounds[p], result,
              [&](const IntervalTree::Range& x) { return of.admits(x.next, x.lo, x.demand); },
              [&](const IntervalTree::Range& x) { return of.admits(x.hi, x.lo, x.demand); }));
    } else {
      result = std::min(result, of.admits_with_slack(shared.largest_slack(p)));
    }
  };
  search(first);
  for (size_t p = 0; p < m.n; ++p) {
    if (p != first) search(p);
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
  Shared shared(m);
  const Nanos largest_overhead = *std::max_element(m.overhead.begin(), m.overhead.end());
  out.max_overhead = kUnbounded;
  Sweep<2> uniform_sweep;
  for (size_t p = 0; p < n; ++p) {
    const Nanos x =
        max_uniform_overhead(m, p, any_checks, shared.base[p], largest_overhead, uniform_sweep);
    out.tasks[m.order[p]].max_overhead = x;
    out.max_overhead = std::min(out.max_overhead, x);
  }

  const bool feasible = shared.feasible();
  for (size_t p = 0; p < n; ++p) {
    TaskSensitivity& s = out.tasks[m.order[p]];
    if (!feasible) {
      s.min_period = kInfeasible;
      s.max_actuations = kInfeasible;
      continue;
    }
    s.min_period = min_period(p, shared);
    s.max_actuations = m.overhead[p] <= 0 ? kUnbounded : max_actuations(p, shared);
  }
  return out;
}

}  // namespace contego::sched
