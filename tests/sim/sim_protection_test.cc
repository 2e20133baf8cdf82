// Scenario runs with protection off and on, through core::Checker loaded
// with the compiled scenario policy; assertions are on the plant (distance,
// speed, gripper pulses, alarm time, dose, angle), not only on verdicts.
#include <algorithm>
#include <gtest/gtest.h>
#include <map>
#include <string>

#include "policy/compile.h"
#include "sim/monitor_guard.h"
#include "sim/report.h"
#include "sim/runner.h"
#include "sim/test_metric.h"

namespace contego::sim {
namespace {

std::string source(const std::string& rel) { return std::string(CONTEGO_SOURCE_DIR) + "/" + rel; }

struct Runs {
  RunResult baseline, unprotected, protected_;
};

// Compiles the scenario's policy once and runs the three modes.
class ProtectionTest : public ::testing::Test {
 protected:
  static Scenario load(const std::string& name) {
    auto sc = load_scenario(source("scenarios/" + name + ".scn"));
    EXPECT_TRUE(sc.ok()) << sc.error();
    return *sc;
  }

  static PolicyImage compile(const Scenario& sc) {
    auto out = policy::compile_file(sc.policy_path);
    std::string diags;
    for (const auto& d : out.diagnostics) diags += d.rendered + "\n";
    EXPECT_TRUE(out.ok) << diags;
    PolicyImage img;
    img.bytes = out.image;
    for (const auto& t : out.model.tasks) img.task_names.push_back(t.name);
    return img;
  }

  static GuardFactory guard(const PolicyImage& img, bool observe) {
    return [&img, observe](bus::VirtualBus& bus) -> Result<std::unique_ptr<Guard>> {
      auto g = MonitorGuard::create(img, bus, observe);
      if (!g) return make_error(g.error());
      return std::unique_ptr<Guard>(std::move(*g));
    };
  }

  static Runs run(const std::string& name, std::optional<uint64_t> seed = {}) {
    const Scenario sc = load(name);
    const PolicyImage img = compile(sc);
    Runs r;
    // The reference mission is the attack-free run with contego on: the
    // policy may correct honest commands (it judges each frame on the state
    // at its own time), and protection should keep that mission, not another.
    auto b = run_scenario(sc, {"baseline", false, guard(img, false), seed});
    auto u = run_scenario(sc, {"unprotected", true, guard(img, true), seed});
    auto p = run_scenario(sc, {"protected", true, guard(img, false), seed});
    EXPECT_TRUE(b.ok() && u.ok() && p.ok());
    if (b.ok()) r.baseline = std::move(*b);
    if (u.ok()) r.unprotected = std::move(*u);
    if (p.ok()) r.protected_ = std::move(*p);
    return r;
  }
};

double at(const RunResult& r, const std::string& col, double t) {
  auto it = std::find(r.columns.begin(), r.columns.end(), col);
  EXPECT_NE(it, r.columns.end()) << col;
  if (it == r.columns.end() || r.rows.empty()) return 0;
  const auto c = static_cast<size_t>(it - r.columns.begin());
  for (const auto& row : r.rows) {
    if (row[0] >= t - 1e-9) return row[c];
  }
  return r.rows.back()[c];
}

double gain(const RunResult& r, const std::string& col, double t0, double t1) {
  return at(r, col, t1) - at(r, col, t0);
}

using sim::testing::metric;

// Fig. 4(a): window 10..20 s.
TEST_F(ProtectionTest, SpoofingStallsTheUnprotectedRoverButNotTheProtectedOne) {
  const Runs r = run("rover_spoof");
  const double nominal = gain(r.baseline, "distance_cm", 10.5, 20.0);
  ASSERT_GT(nominal, 50.0);
  // Unprotected: the encoder distance stands still once the first spoofed job lands.
  EXPECT_LT(gain(r.unprotected, "distance_cm", 10.5, 20.0), 0.05 * nominal);
  // Protected: within 5 % of the attack-free run, during the window and at the end.
  EXPECT_NEAR(at(r.protected_, "distance_cm", 20.0), at(r.baseline, "distance_cm", 20.0),
              0.05 * at(r.baseline, "distance_cm", 20.0));
  EXPECT_NEAR(at(r.protected_, "distance_cm", 30.0), at(r.baseline, "distance_cm", 30.0),
              0.05 * at(r.baseline, "distance_cm", 30.0));
  EXPECT_GT(r.protected_.stats.replaced, 0u);  // FAIL-SAFE substitutes did the work
  EXPECT_GT(r.unprotected.stats.violations, 0u);
}

// Fig. 4(b): window 10..20 s, ten increase_speed frames per job.
TEST_F(ProtectionTest, DosBurstSpeedsTheUnprotectedRoverUpButNotTheProtectedOne) {
  const Runs r = run("rover_dos");
  const double nominal = gain(r.baseline, "distance_cm", 10.0, 20.0) / 10.0;  // cm/s
  const double attacked = gain(r.unprotected, "distance_cm", 10.0, 20.0) / 10.0;
  const double kept = gain(r.protected_, "distance_cm", 10.0, 20.0) / 10.0;
  EXPECT_GT(attacked, 1.5 * nominal);
  EXPECT_NEAR(kept, nominal, 0.05 * nominal);
  // And second by second, not only on average.
  for (double t = 11.0; t <= 20.0; t += 1.0) {
    const double b = at(r.baseline, "speed_cm_s", t);
    EXPECT_NEAR(at(r.protected_, "speed_cm_s", t), b, 0.05 * b) << "t=" << t;
  }
  EXPECT_GT(r.protected_.stats.ignored, 0u);
}

// Fig. 1: the gripper channel's pulses, in order.
TEST_F(ProtectionTest, ProtectedGripperNeverReceivesTheSpoofedPulses) {
  const Runs r = run("arm_high_pulse");
  auto spoofed = [](const RunResult& run) {
    int n = 0;
    for (const auto& e : run.events) {
      if (e.value != 0 && e.value != 420 && e.value != 577) ++n;
    }
    return n;
  };
  EXPECT_EQ(spoofed(r.baseline), 0);
  EXPECT_GT(spoofed(r.unprotected), 5);
  EXPECT_EQ(spoofed(r.protected_), 0);
  EXPECT_GT(r.protected_.events.size(), 10u);
  EXPECT_LT(metric(r.unprotected, "objects_handled"), metric(r.baseline, "objects_handled"));
  EXPECT_EQ(metric(r.protected_, "objects_handled"), metric(r.baseline, "objects_handled"));
}

// A write the chip would take at once (ALL_LED_ON_H alone: every channel
// full on) from a task whose limit on all_led is 0 is answered on that
// write, not held as "allowed (staged)" for a last register that never comes.
TEST_F(ProtectionTest, AllLedTamperingIsDroppedAndSeenNotSilentlyStaged) {
  const Runs r = run("arm_all_led");
  EXPECT_EQ(r.protected_.stats.ignored, r.protected_.stats.injected);
  EXPECT_EQ(r.protected_.stats.violations, r.protected_.stats.injected);
  EXPECT_GT(r.protected_.stats.injected, 0u);
}

// An availability attack made of safe commands: every stop() acts (none is
// dropped: a program's own stop must never be lost to the flood), and every
// one past the policy's one per job is flagged as a violation.
TEST_F(ProtectionTest, AStopFloodIsFlaggedButEveryStopStillActs) {
  const Runs r = run("rover_stop_flood");
  EXPECT_LT(metric(r.unprotected, "distance"), metric(r.baseline, "distance") - 30.0);
  EXPECT_EQ(r.protected_.stats.ignored + r.protected_.stats.rejected, 0u);
  EXPECT_GT(r.protected_.stats.replaced, r.protected_.stats.injected / 2);
  EXPECT_EQ(r.protected_.stats.violations, r.protected_.stats.replaced);
}

// Every platform of Table 1: the attack changes the plant without protection
// and does not with it.
struct PlantCase {
  const char* scenario;
  const char* metric;
  double min_change;  // |unprotected - baseline| at least this
  double tolerance;   // |protected - baseline| at most this
};

class EveryPlatformTest : public ProtectionTest, public ::testing::WithParamInterface<PlantCase> {};

TEST_P(EveryPlatformTest, AttackChangesThePlantOnlyWithoutProtection) {
  const PlantCase& c = GetParam();
  const Runs r = run(c.scenario);
  const double b = metric(r.baseline, c.metric);
  EXPECT_GT(std::abs(metric(r.unprotected, c.metric) - b), c.min_change) << c.metric;
  EXPECT_LE(std::abs(metric(r.protected_, c.metric) - b), c.tolerance) << c.metric;
}

INSTANTIATE_TEST_SUITE_P(
    TableOne, EveryPlatformTest,
    ::testing::Values(PlantCase{"rover_spoof", "distance", 60.0, 15.0},                  // cm
                      PlantCase{"rover_wrong_direction", "track_progress", 30.0, 15.0},  // cm
                      PlantCase{"rover_unauthorised", "distance", 30.0, 15.0},           // cm
                      PlantCase{"arm_high_pulse", "objects_handled", 2.0, 0.0},
                      PlantCase{"arm_sleep", "objects_handled", 2.0, 0.0},
                      PlantCase{"arm_prescale", "objects_handled", 2.0, 0.0},
                      PlantCase{"arm_all_led", "objects_handled", 2.0, 0.0},
                      PlantCase{"arm_unauthorised", "objects_handled", 2.0, 0.0},
                      PlantCase{"tank_false_alarm", "false_alarm_time", 10.0, 0.5},  // s
                      PlantCase{"pump_overdose", "dose_delivered", 5000.0, 50.0},
                      PlantCase{"camera_beyond_range", "max_pan_angle", 20.0, 2.0},  // deg
                      PlantCase{"camera_false_siren", "false_siren_time", 10.0, 0.5}),
    [](const auto& test_info) { return std::string(test_info.param.scenario); });

TEST_F(ProtectionTest, SameSeedGivesAByteIdenticalTraceAndAnotherSeedDoesNot) {
  const Runs a = run("rover_spoof");
  const Runs b = run("rover_spoof");
  const Runs c = run("rover_spoof", uint64_t{2});
  for (auto pick : {&Runs::baseline, &Runs::unprotected, &Runs::protected_}) {
    EXPECT_EQ(trace_csv(a.*pick), trace_csv(b.*pick));
    EXPECT_EQ(ops_csv(a.*pick), ops_csv(b.*pick));
    EXPECT_NE(trace_csv(a.*pick), trace_csv(c.*pick));
  }
}

// The example pump policy checks the dose before the rate cap: after the
// dose an over-fast rate becomes 0, not the capped maximum, so no over-dose
// leaks through (with the cap first, about 600 uL did).
TEST_F(ProtectionTest, ExamplePumpPolicyStopsTheMotorOnceTheDoseIsDelivered) {
  const Runs r = run("pump_overdose");
  const double unprotected = metric(r.unprotected, "overdose");
  const double protected_ = metric(r.protected_, "overdose");
  EXPECT_GT(unprotected, 20000.0);  // uL
  EXPECT_LT(protected_, 50.0);
  EXPECT_LE(metric(r.protected_, "max_rate"), 200.0);
}

// A latch that counts every violation (scenarios/policies/rover-strict.policy)
// holds the spoofed rover in stop() instead; the example policy's latch counts
// only unrepaired violations and keeps it on the line (rover_spoof).
TEST_F(ProtectionTest, ExamplePolicyLatchHoldsTheSpoofedRoverStopped) {
  const Runs r = run("rover_spoof_latch");
  EXPECT_LT(gain(r.protected_, "distance_cm", 11.0, 30.0), 5.0);  // held, even after the attack
  EXPECT_EQ(at(r.protected_, "left_cmd", 25.0), 0.0);
  EXPECT_EQ(at(r.protected_, "right_cmd", 25.0), 0.0);
}

}  // namespace
}  // namespace contego::sim
