// Runs with protection off: the plants, controllers and attacks on their
// own. (The protected runs, through the real checker, are in tests/sim.)
#include "sim/runner.h"

#include <algorithm>
#include <gtest/gtest.h>

#include "sim/test_metric.h"

namespace contego::sim {
namespace {

Scenario rover(const std::string& attack) {
  auto sc = parse_scenario(
      "platform rover\npolicy none\nduration 40s\nseed 3\nattack " + attack + "\n", "t.scn", ".");
  EXPECT_TRUE(sc.ok()) << sc.error();
  return *sc;
}

using testing::metric;

size_t column(const RunResult& r, const std::string& name) {
  auto it = std::find(r.columns.begin(), r.columns.end(), name);
  EXPECT_NE(it, r.columns.end()) << name;
  return static_cast<size_t>(it - r.columns.begin());
}

// Value of `col` at time t (seconds).
double at(const RunResult& r, const std::string& col, double t) {
  const size_t c = column(r, col);
  for (const auto& row : r.rows) {
    if (row[0] >= t - 1e-9) return row[c];
  }
  return r.rows.back()[c];
}

TEST(RunnerTest, VendorLineFollowerStaysOnTheTrack) {
  auto r = run_scenario(rover("spoof from 8s to 16s"), {"baseline", false, nullptr, {}});
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_GT(metric(*r, "distance"), 250.0);     // ~9 cm/s on the straights for 40 s
  EXPECT_LT(metric(*r, "off_line_time"), 0.5);  // never more than 5 cm off for long
  // Round the first bend: the rover has left the straight it started on.
  EXPECT_GT(at(*r, "y_m", 40.0), -0.4);
}

TEST(RunnerTest, SpoofingStallsTheUnprotectedRover) {
  auto r = run_scenario(rover("spoof from 8s to 16s"), {"unprotected", true, nullptr, {}});
  ASSERT_TRUE(r.ok()) << r.error();
  const double d8 = at(*r, "distance_cm", 8.5), d16 = at(*r, "distance_cm", 16.0);
  EXPECT_LT(d16 - d8, 5.0);
  EXPECT_GT(at(*r, "distance_cm", 8.0), 50.0);
  EXPECT_GT(r->stats.injected, 0u);
}

TEST(RunnerTest, DosBurstSpeedsTheUnprotectedRoverUp) {
  auto base = run_scenario(rover("dos from 8s to 16s"), {"baseline", false, nullptr, {}});
  auto r = run_scenario(rover("dos from 8s to 16s"), {"unprotected", true, nullptr, {}});
  ASSERT_TRUE(base.ok() && r.ok());
  const double nominal = at(*base, "distance_cm", 16) - at(*base, "distance_cm", 8);
  const double attacked = at(*r, "distance_cm", 16) - at(*r, "distance_cm", 8);
  EXPECT_GT(attacked, 1.5 * nominal);
}

TEST(RunnerTest, SameSeedSameTraceOtherSeedOtherTrace) {
  auto sc = rover("spoof from 8s to 16s");
  auto a = run_scenario(sc, {"x", true, nullptr, {}});
  auto b = run_scenario(sc, {"x", true, nullptr, {}});
  auto c = run_scenario(sc, {"x", true, nullptr, uint64_t{4}});
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->rows, b->rows);
  EXPECT_NE(a->rows, c->rows);
}

Scenario arm(const std::string& attack) {
  auto sc = parse_scenario("platform arm\npolicy none\nduration 40s\nattack " + attack + "\n",
                           "a.scn", ".");
  EXPECT_TRUE(sc.ok()) << sc.error();
  return *sc;
}

TEST(RunnerTest, ArmPicksAndPlacesEveryObject) {
  auto r = run_scenario(arm("high_pulse from 10s to 22s"), {"baseline", false, nullptr, {}});
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_GE(metric(*r, "objects_handled"), 9.0);  // one per 2 s cycle
  EXPECT_EQ(metric(*r, "objects_lost"), 0.0);
  EXPECT_EQ(metric(*r, "spoofed_grip_pulses"), 0.0);
}

TEST(RunnerTest, HighPulsesReachTheUnprotectedGripperAndCostObjects) {
  auto base = run_scenario(arm("high_pulse from 10s to 22s"), {"baseline", false, nullptr, {}});
  auto r = run_scenario(arm("high_pulse from 10s to 22s"), {"unprotected", true, nullptr, {}});
  ASSERT_TRUE(base.ok() && r.ok());
  EXPECT_GT(metric(*r, "spoofed_grip_pulses"), 5.0);
  EXPECT_LT(metric(*r, "objects_handled"), metric(*base, "objects_handled") - 2);
}

TEST(RunnerTest, ConfigurationTamperingDisturbsTheUnprotectedArm) {
  for (const char* kind : {"sleep", "prescale", "all_led"}) {
    auto base =
        run_scenario(arm(std::string(kind) + " from 10s to 22s"), {"b", false, nullptr, {}});
    auto r = run_scenario(arm(std::string(kind) + " from 10s to 22s"), {"u", true, nullptr, {}});
    ASSERT_TRUE(base.ok() && r.ok());
    EXPECT_LT(metric(*r, "objects_handled"), metric(*base, "objects_handled")) << kind;
  }
}

}  // namespace
}  // namespace contego::sim

namespace contego::sim {
namespace {

Result<RunResult> run_text(const std::string& text, bool attacks) {
  auto sc = parse_scenario(text, "x.scn", ".");
  if (!sc) return make_error(sc.error());
  return run_scenario(*sc, {"x", attacks, nullptr, {}});
}

// The scenario `text` run without its attacks and with them.
struct BaseAndAttacked {
  Result<RunResult> base, bad;
};
BaseAndAttacked run_both(const std::string& text) {
  return {run_text(text, false), run_text(text, true)};
}

using testing::metric;

TEST(RunnerTest, TankMonitorAlarmsOnlyWhenTheLevelIsHigh) {
  const std::string sc =
      "platform tank\npolicy none\nduration 90s\nstep 10ms\ntrace 100ms\n"
      "attack false_alarm from 30s to 50s\n";
  auto [base, bad] = run_both(sc);
  ASSERT_TRUE(base.ok() && bad.ok());
  EXPECT_GT(metric(*base, "buzzer_on_time"), 20.0);   // two high phases of ~15 s
  EXPECT_LT(metric(*base, "false_alarm_time"), 1.5);  // only the 0.5 s polling lag
  EXPECT_GT(metric(*bad, "false_alarm_time"), 15.0);
}

TEST(RunnerTest, PumpStopsAtTheDoseUnlessOverdosed) {
  const std::string sc =
      "platform pump\npolicy none\nduration 30h\nstep 1s\ntrace 1min\nset period 60s\n"
      "attack overdose from 2h to 28h rate=1000\n";
  auto [base, bad] = run_both(sc);
  ASSERT_TRUE(base.ok() && bad.ok());
  EXPECT_NEAR(metric(*base, "dose_delivered"), 5000.0, 10.0);
  EXPECT_NEAR(metric(*base, "dose_reached_at"), 25.0, 0.2);
  EXPECT_GT(metric(*bad, "dose_delivered"), 20000.0);
}

TEST(RunnerTest, CameraPatrolStaysInRangeUnlessSpoofed) {
  const std::string sc =
      "platform camera\npolicy none\nduration 60s\nattack beyond_range from 20s to 40s\n";
  auto [base, bad] = run_both(sc);
  ASSERT_TRUE(base.ok() && bad.ok());
  EXPECT_LT(metric(*base, "max_pan_angle"), 60.0);
  EXPECT_GT(metric(*bad, "max_pan_angle"), 80.0);
  EXPECT_GT(metric(*bad, "time_beyond_range"), 15.0);
}

TEST(RunnerTest, CameraSirenSoundsOnlyWithSomethingInView) {
  const std::string sc =
      "platform camera\npolicy none\nduration 60s\nattack false_siren from 20s to 40s\n";
  auto [base, bad] = run_both(sc);
  ASSERT_TRUE(base.ok() && bad.ok());
  EXPECT_LT(metric(*base, "false_siren_time"), 2.5);  // 1 s polling lag per visit
  EXPECT_GT(metric(*bad, "false_siren_time"), 10.0);
}

}  // namespace
}  // namespace contego::sim
