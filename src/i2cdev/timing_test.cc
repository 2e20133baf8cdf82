// I2C_RETRIES and I2C_TIMEOUT through their C ABI: i2c-core's retry rule
// (__i2c_transfer) and i2c-dev's limits on the ioctls' arguments.
#include <errno.h>

#include <climits>
#include <gtest/gtest.h>

#include "contego/i2c_plan.h"

namespace {

static_assert(CONTEGO_EAGAIN == EAGAIN, "the rule reads Linux's errno numbers");

// Runs a transfer whose driver loses arbitration `lost` times and then
// succeeds, each try taking `per_try`; returns the tries made and the last
// result, as __i2c_transfer's loop would.
struct Outcome {
  uint32_t tries = 0;
  uint32_t err = 0;
};
Outcome run(uint32_t lost, uint32_t retries, uint64_t timeout, uint64_t per_try = 0) {
  Outcome o;
  uint64_t elapsed = 0;
  do {
    o.err = o.tries < lost ? CONTEGO_EAGAIN : 0;
    ++o.tries;
    elapsed += per_try;
  } while (contego_i2c_try_again(o.err, o.tries, retries, elapsed, timeout));
  return o;
}

TEST(I2cTiming, ALostArbitrationIsTriedAgainUpToRetriesTimes) {
  for (uint32_t retries = 0; retries <= 4; ++retries) {
    for (uint32_t lost = 0; lost <= 5; ++lost) {
      const Outcome o = run(lost, retries, 1000);
      EXPECT_EQ(o.err, lost <= retries ? 0u : CONTEGO_EAGAIN) << lost << " of " << retries;
      EXPECT_EQ(o.tries, (lost <= retries ? lost : retries) + 1) << lost << " of " << retries;
    }
  }
}

TEST(I2cTiming, NoRetriesIsOneTry) {
  EXPECT_EQ(run(1, 0, 1000).tries, 1u);
  EXPECT_EQ(contego_i2c_try_again(CONTEGO_EAGAIN, 1, 0, 0, 1000), 0);
}

TEST(I2cTiming, OnlyALostArbitrationIsTriedAgain) {
  EXPECT_EQ(contego_i2c_try_again(0, 1, 3, 0, 1000), 0);
  EXPECT_EQ(contego_i2c_try_again(ENXIO, 1, 3, 0, 1000), 0);  // no acknowledge
  EXPECT_EQ(contego_i2c_try_again(EREMOTEIO, 1, 3, 0, 1000), 0);
  EXPECT_EQ(contego_i2c_try_again(ETIMEDOUT, 1, 3, 0, 1000), 0);
  EXPECT_EQ(contego_i2c_try_again(CONTEGO_EAGAIN, 1, 3, 0, 1000), 1);
}

TEST(I2cTiming, TheTimeoutStopsTheRetriesOnceItHasPassed) {
  // time_after: a try ending exactly at the timeout may be followed by one more.
  EXPECT_EQ(contego_i2c_try_again(CONTEGO_EAGAIN, 1, 3, 70, 70), 1);
  EXPECT_EQ(contego_i2c_try_again(CONTEGO_EAGAIN, 1, 3, 71, 70), 0);
  // 30 per try, timeout 70: tries end at 30, 60, 90; the third is the last.
  const Outcome o = run(10, 100, 70, 30);
  EXPECT_EQ(o.tries, 3u);
  EXPECT_EQ(o.err, CONTEGO_EAGAIN);
  // A zero timeout allows more tries only within the same instant.
  EXPECT_EQ(run(2, 5, 0, 0).err, 0u);
  EXPECT_EQ(run(2, 5, 0, 1).tries, 1u);
}

TEST(I2cTiming, TheIoctlsTakeWhatI2cDevTakes) {
  EXPECT_EQ(contego_i2c_timing_arg_ok(0, 0), 1);
  EXPECT_EQ(contego_i2c_timing_arg_ok(0, INT_MAX), 1);
  EXPECT_EQ(contego_i2c_timing_arg_ok(0, uint64_t{INT_MAX} + 1), 0);
  EXPECT_EQ(contego_i2c_timing_arg_ok(1, INT_MAX / 10), 1);
  EXPECT_EQ(contego_i2c_timing_arg_ok(1, INT_MAX / 10 + 1), 0);
  EXPECT_EQ(contego_i2c_timing_arg_ok(1, UINT64_MAX), 0);
}

}  // namespace
