#include "perf/per_job.h"

#include <gtest/gtest.h>

namespace contego::perf {
namespace {

// The slowest jobs come out slowest first, each with its job number and the
// release instant the grid gives it.
TEST(SlowestJobs, SlowestFirstWithTheirReleaseOnTheGrid) {
  const std::vector<uint64_t> ns = {10, 50, 20, 90, 30};
  const auto s = slowest_jobs(ns, /*first_release_ns=*/1000, /*period_ns=*/100, 3);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].job, 3u);
  EXPECT_EQ(s[0].job_ns, 90u);
  EXPECT_EQ(s[0].release_ns, 1300u);
  EXPECT_EQ(s[1].job, 1u);
  EXPECT_EQ(s[1].release_ns, 1100u);
  EXPECT_EQ(s[2].job, 4u);
  EXPECT_EQ(s[2].job_ns, 30u);
}

// Ties keep job order; asking for more than there are gives them all.
TEST(SlowestJobs, TiesInJobOrderAndNoMoreThanThereAre) {
  const std::vector<uint64_t> ns = {7, 7, 3};
  const auto s = slowest_jobs(ns, 0, 10, 10);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].job, 0u);
  EXPECT_EQ(s[1].job, 1u);
  EXPECT_EQ(s[2].job, 2u);
  EXPECT_TRUE(slowest_jobs({}, 0, 10, 10).empty());
}

}  // namespace
}  // namespace contego::perf
