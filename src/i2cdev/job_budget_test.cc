// The job grid and the hold's counts through their C ABI (the monitor's
// job_grid_test.cc tests the hold end to end).
#include "contego/job_budget.h"

#include <gtest/gtest.h>

namespace {

constexpr uint64_t kPeriod = 10'000;

TEST(JobBudget, JobsAreHalfOpenPeriodsFromThePhase) {
  EXPECT_EQ(contego_grid_job(1000, kPeriod, 500), 1u);  // before the phase: job 1
  EXPECT_EQ(contego_grid_job(1000, kPeriod, 1000), 1u);
  EXPECT_EQ(contego_grid_job(1000, kPeriod, 10'999), 1u);
  EXPECT_EQ(contego_grid_job(1000, kPeriod, 11'000), 2u);
  EXPECT_EQ(contego_grid_job(1000, 0, 11'000), 0u);  // no period, no grid
}

TEST(JobBudget, ADeclaredPhaseKeepsItsGrid) {
  EXPECT_EQ(contego_grid_first_release(0, 0, kPeriod, 12'345), 12'345u);
  EXPECT_EQ(contego_grid_first_release(1, 1000, kPeriod, 12'345), 11'000u);
  EXPECT_EQ(contego_grid_first_release(1, 20'000, kPeriod, 12'345), 20'000u);
  EXPECT_EQ(contego_grid_first_release(1, 1000, 0, 12'345), 12'345u);
}

TEST(JobBudget, PastTheActingBudgetTheNextIsChargedToTheNextJob) {
  contego_job_budget b{};
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(contego_budget_before(&b, 1, kPeriod, 3), 1u);
    EXPECT_EQ(contego_budget_after(&b, 1, kPeriod, 1, 8), 0);
  }
  EXPECT_EQ(contego_budget_before(&b, 1, kPeriod, 3), 2u);  // waits for job 2
  // A second sender meanwhile is charged to job 2 as well.
  EXPECT_EQ(contego_budget_before(&b, 1, kPeriod, 3), 2u);
  EXPECT_EQ(contego_budget_after(&b, 2, kPeriod, 1, 8), 0);
  EXPECT_EQ(b.job, 2u);
  EXPECT_EQ(b.acted, 1u);
  EXPECT_EQ(contego_budget_before(&b, 3, kPeriod, 3), 3u);  // a new release: a fresh budget
  EXPECT_EQ(b.acted, 0u);
}

TEST(JobBudget, DroppedTransfersHoldTheirSenderAfterTheirOwnBudgetOnly) {
  contego_job_budget b{};
  for (int i = 0; i < 8; ++i) EXPECT_EQ(contego_budget_after(&b, 1, kPeriod, 0, 8), 0);
  EXPECT_EQ(contego_budget_after(&b, 1, kPeriod, 0, 8), 1);  // the ninth waits
  EXPECT_EQ(contego_budget_before(&b, 1, kPeriod, 3), 1u);   // acting ones do not
  EXPECT_EQ(contego_budget_after(&b, 1, kPeriod, 1, 8), 0);
}

TEST(JobBudget, ANewGridStartsAFreshBudget) {
  contego_job_budget b{};
  for (int i = 0; i < 3; ++i) contego_budget_after(&b, 1, kPeriod, 1, 8);
  EXPECT_EQ(contego_budget_before(&b, 1, 2 * kPeriod, 3), 1u);
  EXPECT_EQ(b.period_us, 2 * kPeriod);
}

}  // namespace
