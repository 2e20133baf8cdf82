#include "sched/generate.h"

#include <gtest/gtest.h>
#include <numeric>

#include "sched/experiment.h"

namespace contego::sched {
namespace {

TEST(GenerateTest, UUniFastDiscardSumsToTargetWithEveryShareAtMostOne) {
  Generator g(3);
  for (double total : {0.1, 0.9, 1.0, 2.5}) {
    for (int k = 0; k < 200; ++k) {
      const std::vector<double> u = g.uunifast_discard(5, total);
      EXPECT_NEAR(std::accumulate(u.begin(), u.end(), 0.0), total, 1e-9);
      for (double x : u) {
        EXPECT_GE(x, 0.0);
        EXPECT_LE(x, 1.0);
      }
    }
  }
}

TEST(GenerateTest, SetsRespectTheOptionsAndTheSeed) {
  GenOptions o;
  o.tasks = 20;
  o.constrained = true;
  o.actuations_min = 2;
  o.actuations_max = 3;
  ASSERT_TRUE(validate(o).ok());
  Generator a(42);
  Generator b(42);
  for (int k = 0; k < 50; ++k) {
    const TaskSet s = a.generate(o, 0.7);
    const TaskSet t = b.generate(o, 0.7);
    ASSERT_TRUE(validate(s).ok()) << validate(s).error();
    double u = 0;
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      const Task& x = s.tasks[i];
      EXPECT_GE(x.period, o.period_min);
      EXPECT_LE(x.period, o.period_max);
      EXPECT_EQ(x.period % o.period_granularity, 0);
      EXPECT_LE(x.deadline, x.period);
      EXPECT_GE(x.deadline, x.wcet);
      EXPECT_GE(x.actuations, 2);
      EXPECT_LE(x.actuations, 3);
      EXPECT_EQ(x.wcet, t.tasks[i].wcet) << "same seed, same sets";
      u += static_cast<double>(x.wcet) / static_cast<double>(x.period);
    }
    EXPECT_NEAR(u, 0.7, 0.01);  // rounding C to whole nanoseconds
  }
}

TEST(GenerateTest, BadOptionsAreRefused) {
  GenOptions o;
  o.period_max = o.period_min - 1;
  EXPECT_FALSE(validate(o).ok());
  o = {};
  o.actuations_min = 4;
  o.actuations_max = 3;
  EXPECT_FALSE(validate(o).ok());
}

// The same sets are analysed at every overhead, so a larger C^o can only
// lose sets; with free checking and low utilisation RM/DM accepts all
// (Liu & Layland: 20 tasks below 0.69 are always schedulable).
TEST(ExperimentTest, CurvesAreOrderedByOverhead) {
  ExperimentOptions o;
  o.sets_per_point = 60;
  o.u_min = 0.1;
  o.u_max = 0.9;
  o.u_step = 0.2;
  o.overheads = {0, 100'000, 1'000'000};
  ASSERT_TRUE(validate(o).ok());
  const ExperimentResult r = run_experiment(o);
  EXPECT_EQ(r.sets, 5 * 60);
  EXPECT_EQ(r.analyses, 3 * 5 * 60);
  ASSERT_EQ(r.rows.size(), 15u);
  for (size_t k = 0; k < 5; ++k) {
    const ExperimentRow& free = r.rows[k];
    const ExperimentRow& mid = r.rows[5 + k];
    const ExperimentRow& dear = r.rows[10 + k];
    EXPECT_EQ(free.overhead, 0);
    EXPECT_EQ(dear.overhead, 1'000'000);
    EXPECT_GE(free.schedulable, mid.schedulable);
    EXPECT_GE(mid.schedulable, dear.schedulable);
    if (free.utilisation < 0.69) {
      EXPECT_EQ(free.schedulable, free.sets);
    }
  }
  EXPECT_LT(r.rows[14].schedulable, r.rows[4].schedulable) << "1 ms per check must cost sets";
  const std::string csv = experiment_csv(r);
  EXPECT_EQ(csv.rfind("utilisation,overhead_ns,overhead,sets,schedulable,ratio\n", 0), 0u);
  EXPECT_NE(csv.find("0.1000,1000000,1ms,60,"), std::string::npos) << csv;
}

TEST(ExperimentTest, GivenPrioritiesAreRefusedForGeneratedSets) {
  ExperimentOptions o;
  o.assignment = Assignment::kGiven;
  EXPECT_FALSE(validate(o).ok());
}

}  // namespace
}  // namespace contego::sched
