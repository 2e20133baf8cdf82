#include "sched/simulate.h"

#include <gtest/gtest.h>
#include <random>

#include "sched/analysis.h"
#include "sched/test_util.h"

namespace contego::sched {
namespace {

using testing::issue_example;
using testing::ms;
using testing::task;
using testing::us;

// Synchronous release, no checking: hi C=2, T=5; lo C=6, T=10.
// Schedule: hi 0-2, lo 2-5, hi 5-7, lo 7-10: lo's first job ends at 10.
TEST(SimulateTest, HandCheckedPreemptiveSchedule) {
  TaskSet s;
  s.tasks = {task("hi", ms(2), ms(5), ms(5), 2, 0, 0), task("lo", ms(6), ms(10), ms(10), 1, 0, 0)};
  const Result<SimResult> r = simulate(s);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->hyperperiod, ms(10));
  EXPECT_EQ(r->tasks[0].max_response, ms(2));
  EXPECT_EQ(r->tasks[1].max_response, ms(10));
  EXPECT_EQ(r->tasks[0].jobs, 2);
  EXPECT_EQ(r->tasks[1].misses, 0);
}

// A checking section of a lower-priority task blocks a higher one.
// lo: C=1, N=1, C^o=2, released at 0: compute 0-0.5, check 0.5-2.5 (not
// preemptible), compute 2.5-3. hi: C=1, released at 1.5, must wait until
// 2.5, runs 2.5-3.5: response 2 ms (analysis bound: C + B = 1 + 2 = 3 ms).
// lo resumes at 3.5 and ends at 4.0: response 4 ms.
TEST(SimulateTest, CheckingSectionIsNotPreemptible) {
  TaskSet s;
  s.tasks = {task("hi", ms(1), ms(5), ms(5), 2, 0, ms(2)),
             task("lo", ms(1), ms(10), ms(10), 1, 1, ms(2))};
  SimOptions o;
  o.offsets = {us(1500), 0};
  o.horizon = ms(2);  // just the first job of each
  const Result<SimResult> r = simulate(s, o);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->tasks[0].max_response, ms(2));
  EXPECT_EQ(r->tasks[1].max_response, ms(4));
  EXPECT_LE(r->tasks[0].max_response, analyse(s).tasks[0].response);
}

TEST(SimulateTest, RefusesHugeHyperperiodAndDeadlineBeyondPeriod) {
  TaskSet s;
  s.tasks = {task("a", 1, 999'999'937, 999'999'937, 2, 0, 0),
             task("b", 1, 999'999'929, 999'999'929, 1, 0, 0)};
  const Result<SimResult> r = simulate(s);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("hyperperiod exceeds"), std::string::npos) << r.error();
  s.tasks = {task("late", ms(1), ms(10), ms(12), 1, 0, 0)};
  ASSERT_FALSE(simulate(s).ok());
  EXPECT_NE(simulate(s).error().find("exceeds period"), std::string::npos);
}

// Periods from divisors of 200 ms keep every hyperperiod at most 200 ms.
TaskSet random_set(std::mt19937_64& rng, bool with_checking) {
  static constexpr int kPeriodsMs[] = {2, 4, 5, 8, 10, 20, 25, 40, 50, 100, 200};
  std::uniform_int_distribution<size_t> pick(0, std::size(kPeriodsMs) - 1);
  std::uniform_int_distribution<size_t> count(2, 5);
  std::uniform_real_distribution<double> share(0.02, 0.35);
  std::uniform_real_distribution<double> dfrac(0.5, 1.0);
  std::uniform_int_distribution<int> checks(0, 3);
  std::uniform_int_distribution<int> overhead_us(10, 300);
  TaskSet s;
  const size_t n = count(rng);
  for (size_t i = 0; i < n; ++i) {
    const Nanos t = ms(kPeriodsMs[pick(rng)]);
    const Nanos c = std::max<Nanos>(us(10), us(static_cast<double>(t / 1000) * share(rng)));
    const Nanos d = std::max(c, us(static_cast<double>(t / 1000) * dfrac(rng)));
    s.tasks.push_back(task("t" + std::to_string(i), c, t, std::min(d, t),
                           static_cast<int64_t>(n - i), with_checking ? checks(rng) : 0,
                           with_checking ? us(overhead_us(rng)) : 0));
  }
  std::shuffle(s.tasks.begin(), s.tasks.end(), rng);  // priorities stay with their tasks
  return s;
}

// 400 random sets drawn from `seed`, each analysed and simulated; hands
// every task to `check(trial, task, analysis, simulation)` (the task's
// results) and stops at a fatal failure. `random_offsets`: odd trials
// release the tasks at random offsets (drawn after the set, from the same
// generator); the others synchronously.
template <typename Check>
void for_random_tasks(uint64_t seed, bool with_checking, bool random_offsets, Check check) {
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < 400; ++trial) {
    const TaskSet s = random_set(rng, with_checking);
    const Analysis a = analyse(s);
    SimOptions o;
    if (random_offsets && trial % 2 == 1) {
      for (const Task& t : s.tasks) {
        o.offsets.push_back(std::uniform_int_distribution<Nanos>(0, t.period - 1)(rng));
      }
    }
    const Result<SimResult> r = simulate(s, o);
    ASSERT_TRUE(r.ok()) << r.error();
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      check(trial, s.tasks[i], a.tasks[i], r->tasks[i]);
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

// The analysis is safe: over random sets with checking sections, with the
// synchronous pattern and with random release offsets, no simulated job of
// a task the analysis accepts takes longer than R^TEE.
TEST(SimulateTest, SimulatedResponsesNeverExceedTheAnalyticBound) {
  int compared = 0;
  int blocked_runs = 0;
  ASSERT_NO_FATAL_FAILURE(for_random_tasks(
      7, true, true, [&](int trial, const Task& t, const TaskResult& a, const SimTaskStats& r) {
        if (!a.schedulable) return;
        ++compared;
        ASSERT_LE(r.max_response, a.response) << "trial " << trial << " task " << t.name;
        EXPECT_EQ(r.misses, 0);
        if (a.blocking > 0) ++blocked_runs;
      }));
  EXPECT_GT(compared, 500);
  EXPECT_GT(blocked_runs, 200);
}

// The analysis is exact for D <= T without checking sections: with the
// synchronous release (the critical instant) the worst simulated response
// equals R for every task the analysis accepts, and every task it rejects
// misses a deadline in the simulation.
TEST(SimulateTest, WithoutBlockingTheAnalysisIsExact) {
  int equal = 0;
  int rejected = 0;
  ASSERT_NO_FATAL_FAILURE(for_random_tasks(
      11, false, false, [&](int trial, const Task& t, const TaskResult& a, const SimTaskStats& r) {
        if (a.schedulable) {
          ASSERT_EQ(r.max_response, a.response) << "trial " << trial;
          ++equal;
        } else {
          ASSERT_GT(r.misses, 0) << "trial " << trial << " task " << t.name;
          ++rejected;
        }
      }));
  EXPECT_GT(equal, 500);
  EXPECT_GT(rejected, 50);
}

TEST(SimulateTest, IssueExampleStaysWithinTheBound) {
  const TaskSet s = issue_example();
  const Result<SimResult> r = simulate(s);
  ASSERT_TRUE(r.ok()) << r.error();
  const Analysis a = analyse(s);
  for (size_t i = 0; i < 3; ++i) EXPECT_LE(r->tasks[i].max_response, a.tasks[i].response);
}

}  // namespace
}  // namespace contego::sched
