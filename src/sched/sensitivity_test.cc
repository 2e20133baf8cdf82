#include "sched/sensitivity.h"

#include <algorithm>
#include <gtest/gtest.h>
#include <random>

#include "sched/analysis.h"
#include "sched/generate.h"
#include "sched/test_util.h"

namespace contego::sched {
namespace {

using testing::blocking_example;
using testing::issue_example;
using testing::ms;
using testing::task;
using testing::us;

// One task, C = 1, T = D = 4, N = 2: 1 + 2 C^o <= 4  <=>  C^o <= 1.5 ms.
TEST(SensitivityTest, SingleTaskOverheadByHand) {
  TaskSet s;
  s.tasks = {task("only", ms(1), ms(4), ms(4), 1, 2, us(100))};
  const Sensitivity sens = sensitivity(s);
  EXPECT_EQ(sens.max_overhead, us(1500));
  EXPECT_EQ(sens.tasks[0].max_overhead, us(1500));
  // N: 1 + N * 0.1 <= 4  <=>  N <= 30.
  EXPECT_EQ(sens.tasks[0].max_actuations, 30);
  // Smallest implicit-deadline period: C^TEE = 1.2 ms.
  EXPECT_EQ(sens.tasks[0].min_period, us(1200));
}

// hi: C=1, T=D=3, N=0, prio 2;  lo: C=1, T=D=100, N=5, prio 1;  C^o = 0.2 ms.
//   max C^o: hi is blocked by 5 C^o: 1 + 5x <= 3  <=> x <= 0.4 ms (lo tolerates
//     far more: its own 1 + 5x plus hi's jobs fit in 100 ms up to ~15 ms).
//   min period of hi: R_hi = 1 + 5*0.2 = 2 does not depend on T_hi; lo at
//     T_hi = 2: r = 2 + ceil(r/2)*1: 2 -> 3 -> 4 -> 4 <= 100. At T_hi below
//     2, hi's own deadline fails. So 2 ms.
//   max N_hi: 1 + 0.2 N + 1 <= 3  <=> N <= 5 (lo: 2 + ceil(r/3)*2 -> 6, fine).
//   max N_lo: 1 + 0.2 N <= 3 for hi  <=> N <= 10.
TEST(SensitivityTest, BlockingDominatedSetByHand) {
  TaskSet s = blocking_example(us(200));
  const Sensitivity sens = sensitivity(s);
  EXPECT_EQ(sens.max_overhead, us(400));
  EXPECT_EQ(sens.tasks[0].max_overhead, us(400));
  EXPECT_GT(sens.tasks[1].max_overhead, ms(10));
  EXPECT_EQ(sens.tasks[0].min_period, ms(2));
  EXPECT_EQ(sens.tasks[0].max_actuations, 5);
  EXPECT_EQ(sens.tasks[1].max_actuations, 10);
}

// The figures are boundaries of the exact test: at the figure the set
// passes, one nanosecond / one command beyond it fails.
TEST(SensitivityTest, FiguresAreTightBoundariesOnIssueExample) {
  const TaskSet s = issue_example();
  const Sensitivity sens = sensitivity(s);
  ASSERT_GT(sens.max_overhead, 0);
  ASSERT_LT(sens.max_overhead, kUnbounded);
  EXPECT_TRUE(is_schedulable(resolve_overheads(s, sens.max_overhead, 0)));
  EXPECT_FALSE(is_schedulable(resolve_overheads(s, sens.max_overhead + 1, 0)));
  for (size_t i = 0; i < s.tasks.size(); ++i) {
    TaskSet p = s;
    p.tasks[i].actuations = sens.tasks[i].max_actuations;
    EXPECT_TRUE(is_schedulable(p)) << i;
    p.tasks[i].actuations += 1;
    EXPECT_FALSE(is_schedulable(p)) << i;
    p = s;
    p.tasks[i].period = p.tasks[i].deadline = sens.tasks[i].min_period;
    EXPECT_TRUE(is_schedulable(p)) << i;
    p.tasks[i].period = p.tasks[i].deadline = sens.tasks[i].min_period - 1;
    EXPECT_FALSE(is_schedulable(p)) << i;
  }
}

TEST(SensitivityTest, NoCheckedCommandsMeansOverheadIsUnbounded) {
  TaskSet s;
  s.tasks = {task("a", ms(1), ms(4), ms(4), 2, 0, 0), task("b", ms(1), ms(8), ms(8), 1, 0, 0)};
  const Sensitivity sens = sensitivity(s);
  EXPECT_EQ(sens.max_overhead, kUnbounded);
  EXPECT_EQ(sens.tasks[0].max_actuations, kUnbounded);  // C^o = 0: checks are free
}

TEST(SensitivityTest, InfeasibleSetReportsInfeasible) {
  TaskSet s;
  s.tasks = {task("a", ms(5), ms(4), ms(4), 1, 1, 0)};
  const Sensitivity sens = sensitivity(s);
  EXPECT_EQ(sens.max_overhead, kInfeasible);
  EXPECT_EQ(sens.tasks[0].min_period, kInfeasible);
  EXPECT_EQ(sens.tasks[0].max_actuations, kInfeasible);
}

void expect_same(const TaskSet& s, const std::string& what) {
  const Sensitivity fast = sensitivity(s);
  const Sensitivity ref = sensitivity_by_search(s);
  ASSERT_EQ(fast.tasks.size(), ref.tasks.size());
  EXPECT_EQ(fast.max_overhead, ref.max_overhead) << what;
  for (size_t i = 0; i < s.tasks.size(); ++i) {
    EXPECT_EQ(fast.tasks[i].max_overhead, ref.tasks[i].max_overhead) << what << " task " << i;
    EXPECT_EQ(fast.tasks[i].min_period, ref.tasks[i].min_period) << what << " task " << i;
    EXPECT_EQ(fast.tasks[i].max_actuations, ref.tasks[i].max_actuations) << what << " task " << i;
  }
}

TEST(SensitivityTest, HandExamplesMatchTheSearch) {
  expect_same(issue_example(), "issue example");
  TaskSet s = blocking_example(us(200));
  expect_same(s, "blocking");
  // A task far below many short periods: thousands of scheduling points
  // before its deadline, so the jumps hand over to their bounded search.
  TaskSet many;
  many.tasks = {task("fast", us(3), us(10), us(10), 3, 1, us(1)),
                task("mid", us(40), us(170), us(150), 2, 2, us(2)),
                task("slow", ms(20), ms(100), ms(90), 1, 3, us(5))};
  expect_same(many, "many points");
}

// Durations near kMaxDuration, periods of a few nanoseconds below long
// deadlines and N C^o that saturates C^TEE: the incremental demand caps its
// sums just above kMaxDuration and counts many releases at once when an
// iterate jumps several periods, and the uniform C^o search hands over to
// a branch and bound after many fixed points; none of it may change a
// figure.
TEST(SensitivityTest, ExtremeValuesMatchTheSearch) {
  std::mt19937_64 rng(151);
  const Nanos scales[] = {1, 1'000, 1'000'000, kMaxDuration / 4};
  int feasible = 0, jumps = 0;
  for (int k = 0; k < 400; ++k) {
    TaskSet s;
    const size_t n = 1 + rng() % 5;
    for (size_t i = 0; i < n; ++i) {
      const Nanos scale = scales[rng() % 4];
      const Nanos period = std::min(kMaxDuration, scale + static_cast<Nanos>(rng() % 4) * scale);
      const Nanos deadline =
          std::max<Nanos>(1, period - static_cast<Nanos>(rng() % 2) * period / 3);
      const Nanos wcet = std::max<Nanos>(1, deadline / static_cast<Nanos>(2 + rng() % 50));
      const int64_t actuations = rng() % 8 == 0 ? 1'000'000 : static_cast<int64_t>(rng() % 4);
      const Nanos overhead = rng() % 8 == 0 ? kMaxDuration : static_cast<Nanos>(rng() % 1000);
      s.tasks.push_back(task("t" + std::to_string(i), wcet, period, deadline,
                             static_cast<int64_t>(rng() % 4), actuations, overhead));
    }
    ASSERT_TRUE(validate(s).ok()) << validate(s).error();
    feasible += is_schedulable(s) ? 1 : 0;
    const auto [shortest, longest] =
        std::minmax_element(s.tasks.begin(), s.tasks.end(),
                            [](const Task& a, const Task& b) { return a.period < b.period; });
    jumps += longest->deadline > 1000 * shortest->period ? 1 : 0;
    expect_same(s, "extreme set " + std::to_string(k));
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(feasible, 60);
  EXPECT_GT(jumps, 80);  // a deadline spans a thousand periods of another task
}

// The interval search against the binary search of whole-set analyses, over
// random sets: feasible and infeasible, implicit and constrained deadlines,
// sets without checked commands, per-task and zero overheads, distinct
// (DM) and random priorities with ties.
TEST(SensitivityTest, IntervalSearchEqualsTheBinarySearchOnRandomSets) {
  std::mt19937_64 rng(15);
  Generator gen(15);
  int infeasible = 0, unchecked = 0, ties = 0, constrained = 0;
  for (int k = 0; k < 3000; ++k) {
    GenOptions o;
    o.tasks = 1 + rng() % 9;
    o.period_min = us(100);
    o.period_max = ms(20);
    o.period_granularity = 1 + rng() % 2 * 999;
    o.constrained = rng() % 2 == 0;
    const bool no_checks = rng() % 10 == 0;
    o.actuations_min = 0;
    o.actuations_max = no_checks ? 0 : 1 + static_cast<int64_t>(rng() % 5);
    const double u = 0.05 + static_cast<double>(rng() % 110) / 100.0;  // some beyond 1
    TaskSet s = gen.generate(o, std::min(u, 0.99 * static_cast<double>(o.tasks)));
    const int priorities = static_cast<int>(rng() % 3);  // 0 DM-like, 1 random, 2 few levels
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      Task& t = s.tasks[i];
      t.overhead = rng() % 8 == 0 ? 0 : static_cast<Nanos>(rng() % 20'000);
      if (priorities == 0) t.priority = -t.deadline;
      if (priorities == 1) t.priority = static_cast<int64_t>(rng() % 1000);
      if (priorities == 2) t.priority = static_cast<int64_t>(rng() % 3);
    }
    ASSERT_TRUE(validate(s).ok()) << validate(s).error();
    infeasible += is_schedulable(s) ? 0 : 1;
    unchecked += no_checks ? 1 : 0;
    ties += priorities == 2 && s.tasks.size() > 3 ? 1 : 0;
    constrained += o.constrained ? 1 : 0;
    expect_same(s, "set " + std::to_string(k));
    if (::testing::Test::HasFailure()) return;
  }
  // The edge cases were all visited.
  EXPECT_GT(infeasible, 100);
  EXPECT_GT(unchecked, 100);
  EXPECT_GT(ties, 100);
  EXPECT_GT(constrained, 1000);
}

}  // namespace
}  // namespace contego::sched
