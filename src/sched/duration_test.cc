#include "sched/duration.h"

#include <gtest/gtest.h>
#include <random>

namespace contego::sched {
namespace {

TEST(DurationTest, ParsesEveryUnitExactly) {
  EXPECT_EQ(*parse_duration("1ms"), 1'000'000);
  EXPECT_EQ(*parse_duration("250us"), 250'000);
  EXPECT_EQ(*parse_duration("250µs"), 250'000);
  EXPECT_EQ(*parse_duration("2.5ms"), 2'500'000);
  EXPECT_EQ(*parse_duration("1s"), 1'000'000'000);
  EXPECT_EQ(*parse_duration("500ns"), 500);
  EXPECT_EQ(*parse_duration("0.000001s"), 1'000);
  EXPECT_EQ(*parse_duration("1.000000001s"), 1'000'000'001);
  EXPECT_EQ(*parse_duration(" 20us "), 20'000);
  EXPECT_EQ(*parse_duration("0"), 0);
  EXPECT_EQ(*parse_duration("0us"), 0);
}

TEST(DurationTest, RefusesWhatIsNotAnExactDuration) {
  for (const char* bad : {"", "ms", "1", "10", "1.5", "-1ms", "1.ms", ".5ms", "0.5ns", "1.0001us0",
                          "1 m s", "1min", "1e3ms", "1000001s", "99999999999999999999ns"}) {
    EXPECT_FALSE(parse_duration(bad).ok()) << bad;
  }
  EXPECT_NE(parse_duration("10").error().find("missing unit"), std::string::npos);
  EXPECT_NE(parse_duration("0.5ns").error().find("finer than a nanosecond"), std::string::npos);
}

TEST(DurationTest, FormatsInTheLargestReadableUnit) {
  EXPECT_EQ(format_duration(2'500'000), "2.5ms");
  EXPECT_EQ(format_duration(20'000), "20us");
  EXPECT_EQ(format_duration(1'500), "1.5us");
  EXPECT_EQ(format_duration(15'500'000), "15.5ms");
  EXPECT_EQ(format_duration(1'000'000'001), "1.000000001s");
  EXPECT_EQ(format_duration(7), "7ns");
  EXPECT_EQ(format_duration(0), "0");
  EXPECT_EQ(format_duration(-500'000), "-500us");
}

TEST(DurationTest, FormatThenParseRoundTrips) {
  std::mt19937_64 rng(5);
  std::uniform_int_distribution<Nanos> any(0, kMaxDuration);
  for (int i = 0; i < 20000; ++i) {
    const Nanos v = i < 1000 ? i : any(rng) / (Nanos{1} << (i % 40));
    Result<Nanos> back = parse_duration(format_duration(v));
    ASSERT_TRUE(back.ok()) << format_duration(v) << ": " << back.error();
    EXPECT_EQ(*back, v);
  }
}

TEST(DurationTest, SaturatingHelpersClampInsteadOfWrapping) {
  const Nanos max = std::numeric_limits<Nanos>::max();
  EXPECT_EQ(sat_add(max, 1), max);
  EXPECT_EQ(sat_mul(max / 2, 3), max);
  EXPECT_EQ(sat_mul(4, 5), 20);
}

}  // namespace
}  // namespace contego::sched
