#include "sched/sensitivity.h"

#include <gtest/gtest.h>

#include "sched/analysis.h"
#include "sched/test_util.h"

namespace contego::sched {
namespace {

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
  TaskSet s;
  s.tasks = {task("hi", ms(1), ms(3), ms(3), 2, 0, us(200)),
             task("lo", ms(1), ms(100), ms(100), 1, 5, us(200))};
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

}  // namespace
}  // namespace contego::sched
