// The release of a task's first job on its period grid: from its first
// contact, or from a declared phase on the monitor's clock.
#include <gtest/gtest.h>
#include <optional>

#include "monitor/monitor.h"

namespace contego::monitor {
namespace {

TEST(JobGrid, WithoutADeclaredPhaseJobOneStartsAtTheFirstContact) {
  EXPECT_EQ(first_release_us(std::nullopt, 200000, 1234567), 1234567u);
}

TEST(JobGrid, ADeclaredPhasePutsJobOneOnTheGridAtOrBeforeTheContact) {
  // period 200 ms, phase 50 ms: releases at 50, 250, 450 ... ms.
  EXPECT_EQ(first_release_us(50000, 200000, 460000), 450000u);
  EXPECT_EQ(first_release_us(50000, 200000, 450000), 450000u);
  EXPECT_EQ(first_release_us(50000, 200000, 449999), 250000u);
  EXPECT_EQ(first_release_us(0, 200000, 1000001), 1000000u);
}

TEST(JobGrid, AContactBeforeTheFirstDeclaredReleaseBelongsToJobOne) {
  EXPECT_EQ(first_release_us(50000, 200000, 10000), 50000u);
}

TEST(JobGrid, NoPeriodKeepsTheContact) { EXPECT_EQ(first_release_us(50000, 0, 777), 777u); }

}  // namespace
}  // namespace contego::monitor
