#include "sim/noise.h"

#include <cmath>
#include <gtest/gtest.h>

namespace contego::sim {
namespace {

TEST(NoiseTest, SameSeedGivesSameSequence) {
  Noise a(42), b(42);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.next_u64(), b.next_u64());
}

TEST(NoiseTest, DifferentSeedsDiffer) {
  Noise a(1), b(2);
  int same = 0;
  for (int i = 0; i < 100; ++i) same += a.next_u64() == b.next_u64();
  EXPECT_EQ(same, 0);
}

TEST(NoiseTest, GaussianHasTheRequestedSpread) {
  Noise n(7);
  double sum = 0, sq = 0;
  const int k = 20000;
  for (int i = 0; i < k; ++i) {
    const double v = n.gaussian(3.0);
    sum += v;
    sq += v * v;
  }
  EXPECT_NEAR(sum / k, 0.0, 0.1);
  EXPECT_NEAR(std::sqrt(sq / k), 3.0, 0.1);
}

TEST(NoiseTest, UniformIntStaysInItsRange) {
  Noise n(9);
  bool saw_lo = false, saw_hi = false;
  for (int i = 0; i < 1000; ++i) {
    const auto v = n.uniform_int(3, 6);
    ASSERT_GE(v, 3);
    ASSERT_LE(v, 6);
    saw_lo |= v == 3;
    saw_hi |= v == 6;
  }
  EXPECT_TRUE(saw_lo && saw_hi);
}

TEST(NoiseTest, DerivedStreamsAreIndependentOfEachOther) {
  EXPECT_NE(derive_seed(1, 1), derive_seed(1, 2));
  EXPECT_EQ(derive_seed(5, 3), derive_seed(5, 3));
}

}  // namespace
}  // namespace contego::sim
