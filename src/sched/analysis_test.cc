#include "sched/analysis.h"

#include <algorithm>
#include <gtest/gtest.h>

#include "sched/assign.h"
#include "sched/generate.h"
#include "sched/test_util.h"

namespace contego::sched {
namespace {

using namespace testing;  // NOLINT(google-build-using-namespace): the sched test helpers

// Issue 5's example, by hand, C^o = 0.5 ms:
//   C^TEE: t1 = 1 + 1*0.5 = 1.5, t2 = 2 + 2*0.5 = 3, t3 = 3 + 1*0.5 = 3.5
//   B:     t1 = max(2*0.5, 1*0.5) = 1, t2 = 1*0.5 = 0.5, t3 = 0 (lowest)
//   R1 = 1.5 + 1 = 2.5
//   R2: 3.5 -> 3.5 + 1*1.5 = 5 -> 3.5 + 2*1.5 = 6.5 -> 6.5 (fixed point)
//   R3: 3.5 -> 3.5+1.5+3 = 8 -> 3.5+2*1.5+3 = 9.5 -> 3.5+3*1.5+3 = 11
//       -> 3.5+3*1.5+2*3 = 14 -> 3.5+4*1.5+2*3 = 15.5 -> 15.5 (fixed point)
TEST(AnalysisTest, IssueExampleMatchesHandComputation) {
  const Analysis a = analyse(issue_example());
  ASSERT_EQ(a.tasks.size(), 3u);
  EXPECT_EQ(a.tasks[0].c_tee, us(1500));
  EXPECT_EQ(a.tasks[1].c_tee, ms(3));
  EXPECT_EQ(a.tasks[2].c_tee, us(3500));
  EXPECT_EQ(a.tasks[0].blocking, ms(1));
  EXPECT_EQ(a.tasks[1].blocking, us(500));
  EXPECT_EQ(a.tasks[2].blocking, 0);
  EXPECT_EQ(a.tasks[0].response, us(2500));
  EXPECT_EQ(a.tasks[1].response, us(6500));
  EXPECT_EQ(a.tasks[2].response, us(15500));
  EXPECT_EQ(a.tasks[2].slack(), us(4500));
  for (const TaskResult& r : a.tasks) EXPECT_TRUE(r.schedulable);
  EXPECT_TRUE(a.schedulable);
  EXPECT_TRUE(is_schedulable(issue_example()));
}

// The input order must not matter: results come back in input order.
TEST(AnalysisTest, ResultsFollowInputOrderNotPriorityOrder) {
  TaskSet s = issue_example();
  std::swap(s.tasks[0], s.tasks[2]);  // t3, t2, t1
  const Analysis a = analyse(s);
  EXPECT_EQ(a.tasks[0].response, us(15500));
  EXPECT_EQ(a.tasks[2].response, us(2500));
}

// Blocking alone causes the miss. hi: C=1, T=D=3, N=0, prio 2;
// lo: C=1, T=D=100, N=5, prio 1; C^o = 0.5 ms.
//   Without checking cost R_hi = 1 <= 3.
//   With it, B_hi = N_lo * C^o = 5 * 0.5 = 2.5, so R_hi = 1 + 2.5 = 3.5 > 3: miss,
//   although hi itself checks nothing and nothing preempts it.
//   lo: C^TEE = 1 + 2.5 = 3.5; r = 3.5 -> 3.5 + ceil(3.5/3)*1 = 5.5 -> 5.5: meets 100.
TEST(AnalysisTest, BlockingAloneMakesHigherPriorityTaskMiss) {
  TaskSet s = blocking_example(us(500));
  const Analysis a = analyse(s);
  EXPECT_EQ(a.tasks[0].blocking, us(2500));
  EXPECT_EQ(a.tasks[0].response, us(3500));
  EXPECT_FALSE(a.tasks[0].schedulable);
  EXPECT_EQ(a.tasks[0].iterations, 0);  // C^TEE + B already exceeds D
  EXPECT_TRUE(a.tasks[1].schedulable);
  EXPECT_EQ(a.tasks[1].response, us(5500));
  EXPECT_FALSE(a.schedulable);

  s = resolve_overheads(s, Nanos{0}, 0);
  EXPECT_TRUE(is_schedulable(s)) << "free checking: no blocking, no miss";
}

// The iteration stops at the first iterate beyond D instead of running on
// to the fixed point. C^o = 0.5 ms.
//   a: C=1, N=2, T=D=5, prio 2: C^TEE = 2, B = 1*0.5 = 0.5, R = 2.5.
//   b: C=6, N=1, T=D=10, prio 1: C^TEE = 6.5, B = 0.
//      r = 6.5 (paper: r^(1) from r^(0) = 0) -> 6.5 + ceil(6.5/5)*2 = 10.5 > 10: stop.
//   Carried on, it would reach 6.5 + ceil(10.5/5)*2 = 12.5, the true fixed
//   point; the analysis must report 10.5 after one step from C^TEE + B.
TEST(AnalysisTest, IterationStopsAtFirstIterateBeyondDeadline) {
  TaskSet s;
  s.tasks = {task("a", ms(1), ms(5), ms(5), 2, 2, us(500)),
             task("b", ms(6), ms(10), ms(10), 1, 1, us(500))};
  const Analysis a = analyse(s);
  EXPECT_EQ(a.tasks[0].response, us(2500));
  EXPECT_FALSE(a.tasks[1].schedulable);
  EXPECT_EQ(a.tasks[1].response, us(10500));
  EXPECT_EQ(a.tasks[1].iterations, 1);
  EXPECT_EQ(a.tasks[1].slack(), -us(500));
}

// R == D is a pass (the test is R <= D). hi: C=2, T=D=5; lo: C=6, T=D=10,
// no checking: 6 -> 8 -> 6 + 2*2 = 10 -> 10.
TEST(AnalysisTest, ResponseEqualToDeadlineIsSchedulable) {
  TaskSet s;
  s.tasks = {task("hi", ms(2), ms(5), ms(5), 2, 0, 0), task("lo", ms(6), ms(10), ms(10), 1, 0, 0)};
  const Analysis a = analyse(s);
  EXPECT_EQ(a.tasks[1].response, ms(10));
  EXPECT_TRUE(a.tasks[1].schedulable);
  s.tasks[1].wcet += 1;  // one nanosecond more: 10ms + 1ns -> ceil = 3 jobs of hi
  EXPECT_FALSE(analyse(s).tasks[1].schedulable);
}

// Equal priorities interfere with each other (SCHED_FIFO runs equals in
// arrival order, so either may wait for the other), and neither blocks the
// other. x, y: C=1, T=D=10, prio 5, N=1, C^o=0.5:
//   C^TEE = 1.5 each, B = 0 (nothing strictly lower), R = 1.5 + 1.5 = 3.
TEST(AnalysisTest, EqualPrioritiesInterfereBothWays) {
  TaskSet s;
  s.tasks = {task("x", ms(1), ms(10), ms(10), 5, 1, us(500)),
             task("y", ms(1), ms(10), ms(10), 5, 1, us(500)),
             task("z", ms(1), ms(20), ms(20), 1, 4, us(500))};
  const Analysis a = analyse(s);
  EXPECT_EQ(a.tasks[0].response, ms(3) + ms(2));  // + B = 4 * 0.5 from z
  EXPECT_EQ(a.tasks[1].response, ms(5));
  EXPECT_EQ(a.tasks[0].blocking, ms(2));
  // z: C^TEE = 3, r = 3 + 1.5 + 1.5 = 6 -> 6.
  EXPECT_EQ(a.tasks[2].response, ms(6));
}

// Saturating arithmetic: absurd but valid inputs give a verdict, not UB.
TEST(AnalysisTest, HugeValuesDoNotOverflow) {
  TaskSet s;
  s.tasks = {task("fast", 1, 1, 1, 2, 1000000, kMaxDuration),
             task("slow", kMaxDuration, kMaxDuration, kMaxDuration, 1, 1000000, kMaxDuration)};
  const Analysis a = analyse(s);
  EXPECT_FALSE(a.schedulable);
  EXPECT_GT(a.tasks[1].response, kMaxDuration);
}

TEST(AnalysisTest, ResponseTimeOfLoneTaskIsItsCheckedWcet) {
  const Response r = response_time(ms(3), 0, ms(3), {});
  EXPECT_TRUE(r.schedulable);
  EXPECT_EQ(r.response, ms(3));
}

// The verdict-only path starts its iteration higher (meets_deadline): the
// same verdict as the full analysis on random sets around the edge of
// schedulability, constrained deadlines and equal priorities included.
TEST(AnalysisTest, VerdictOnlyAgreesWithTheFullAnalysis) {
  Generator gen(7);
  size_t feasible = 0;
  for (size_t k = 0; k < 600; ++k) {
    GenOptions o;
    o.tasks = 2 + k % 30;
    o.constrained = k % 2 == 0;
    TaskSet s = gen.generate(o, 0.5 + 0.5 * static_cast<double>(k % 100) / 100.0);
    for (Task& t : s.tasks) t.overhead = static_cast<Nanos>(k % 7) * 20'000;
    s = assign_priorities(s, Assignment::kDeadlineMonotonic).set;
    if (k % 3 == 0) {
      for (size_t i = 0; i + 1 < s.tasks.size(); i += 2)
        s.tasks[i].priority = s.tasks[i + 1].priority;
    }
    const bool full = analyse(s).schedulable;
    ASSERT_EQ(Analyzer().schedulable(s), full) << "set " << k;
    feasible += full ? 1 : 0;
  }
  EXPECT_GT(feasible, 50u);  // both verdicts are exercised
  EXPECT_LT(feasible, 550u);
}

// The textbook recurrence, every ceiling divided afresh at every step: the
// analysis (which divides only when a job count can change) gives the same
// iterates, so the same R_i, miss iterate and step count for every task.
TEST(AnalysisTest, EveryTaskMatchesTheTextbookRecurrence) {
  Generator gen(11);
  for (size_t k = 0; k < 400; ++k) {
    GenOptions o;
    o.tasks = 2 + k % 40;
    o.constrained = k % 2 == 1;
    TaskSet s = gen.generate(o, 0.4 + 0.6 * static_cast<double>(k % 100) / 100.0);
    for (Task& t : s.tasks) t.overhead = static_cast<Nanos>(k % 5) * 30'000;
    s = assign_priorities(s, Assignment::kDeadlineMonotonic).set;
    if (k % 4 == 0) {
      for (size_t i = 0; i + 1 < s.tasks.size(); i += 2)
        s.tasks[i].priority = s.tasks[i + 1].priority;
    }
    const Analysis a = analyse(s);
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      const Task& me = s.tasks[i];
      Nanos blocking = 0;
      for (const Task& t : s.tasks) {
        if (t.priority < me.priority) blocking = std::max(blocking, t.actuations * t.overhead);
      }
      const Nanos own = checked_wcet(me) + blocking;
      Nanos r = own;
      int steps = 0;
      while (r <= me.deadline) {
        Nanos next = own;
        for (size_t j = 0; j < s.tasks.size(); ++j) {
          const Task& h = s.tasks[j];
          if (j != i && h.priority >= me.priority) {
            next += (r + h.period - 1) / h.period * checked_wcet(h);
          }
        }
        ++steps;
        if (next == r) break;
        r = next;
      }
      ASSERT_EQ(a.tasks[i].response, r) << "set " << k << " task " << i;
      ASSERT_EQ(a.tasks[i].schedulable, r <= me.deadline) << "set " << k << " task " << i;
      ASSERT_EQ(a.tasks[i].iterations, steps) << "set " << k << " task " << i;
    }
  }
}

}  // namespace
}  // namespace contego::sched
