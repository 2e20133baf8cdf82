// End-to-end tests of the compiler: policy text → image → core::Checker.
// The lowered programs are executed by the trusted core itself, so these
// tests pin the meaning of the language, not just its syntax.
#include "policy/compile.h"

#include <cstring>
#include <gtest/gtest.h>
#include <memory>
#include <optional>
#include <vector>

#include "contego/core/checker.h"

#include "policy/test_util.h"

namespace contego::policy {
namespace {

using core::Decision;

constexpr const char* kRover = R"(
const THETA = 2500
device gopigo : gopigo2 at i2c-1 0x08 { safe stop() }
device line : line_follower at i2c-1 0x06 sample 10ms max_age 100ms
signal pos = line_position(line.raw,
    white=[767, 815, 859, 710, 700], black=[1012, 1013, 1015, 1003, 1004],
    weights=[-100, -50, 0, 50, 100])
task follower { exe "/usr/bin/python3"; period 200ms; wcet 40ms; priority 2; actuations 3 }
allow follower -> gopigo
allow follower reads line
limit follower -> gopigo 3 per job else ignore
invariant INV1 on gopigo: when pos < -THETA
  expect set_left_speed(85), set_right_speed(85), right() else failsafe expected
invariant INV2 on gopigo: when pos > THETA
  expect set_left_speed(125), set_right_speed(125), left() else failsafe expected
invariant INV3 on gopigo: when pos in -THETA..THETA
  expect set_left_speed(80), set_right_speed(80), fwd() else failsafe expected
)";

// A host whose line follower reports fixed raw readings.
struct Sensors {
  uint16_t raw[5] = {767, 815, 859, 710, 700};  // all white: pos = 0
  bool present = true;
};

uint32_t read_sample(void* ctx, uint16_t /*device*/, uint8_t* buf, uint32_t capacity,
                     uint64_t* taken_at_us) {
  auto* s = static_cast<Sensors*>(ctx);
  if (!s->present || capacity < 10) return 0;
  for (int i = 0; i < 5; ++i) {
    buf[2 * i] = static_cast<uint8_t>(s->raw[i] >> 8);
    buf[2 * i + 1] = static_cast<uint8_t>(s->raw[i] & 0xFF);
  }
  *taken_at_us = 1000;
  return 10;
}

class RoverPolicy : public ::testing::Test {
 protected:
  void SetUp() override {
    out_ = compile_source("rover.policy", kRover);
    ASSERT_TRUE(out_.ok) << (out_.diagnostics.empty() ? "" : out_.diagnostics[0].rendered);
    checker_ = std::make_unique<core::Checker>();
    ASSERT_EQ(checker_->load(out_.image.data(), static_cast<uint32_t>(out_.image.size())).status,
              core::LoadStatus::kOk);
    core::Host host{};
    host.context = &sensors_;
    host.read_sample = read_sample;
    checker_->set_host(host);
  }

  core::Verdict send(std::vector<uint8_t> frame, uint32_t job) {
    const core::Transaction tx = testing::write_tx(0, 0x08, job, frame.data(), frame.size(), 2000);
    core::Verdict v{};
    checker_->check(tx, &v);
    return v;
  }
  static std::vector<uint8_t> emitted(const core::Verdict& v) {
    return std::vector<uint8_t>(v.emit_bytes, v.emit_bytes + v.emit_bytes_used);
  }

  CompileOutput out_;
  std::unique_ptr<core::Checker> checker_;
  Sensors sensors_;
};

TEST_F(RoverPolicy, WorstCaseCostComesFromTheVerifierAndMatchesOurBound) {
  EXPECT_GT(out_.worst_case_cost, 0u);
  EXPECT_EQ(out_.worst_case_cost, out_.estimated_cost);
}

TEST_F(RoverPolicy, Inv1AllowsTheExpectedSpeedWhenTheLineIsFarLeft) {
  sensors_.raw[0] = 1012;  // two left sensors on black: pos = -15000
  sensors_.raw[1] = 1013;
  const core::Verdict v = send({0x46, 85, 0, 0}, 1);
  EXPECT_EQ(v.decision, Decision::kAllow);
}

TEST_F(RoverPolicy, Inv1SubstitutesTheExpectedSpeedForAnotherSpeed) {
  sensors_.raw[0] = 1012;
  sensors_.raw[1] = 1013;
  const core::Verdict v = send({0x46, 200, 0, 0}, 1);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(emitted(v), (std::vector<uint8_t>{0x46, 85, 0, 0}));
}

TEST_F(RoverPolicy, Inv1ReplacesAnotherMotionCommandByRight) {
  sensors_.raw[0] = 1012;
  sensors_.raw[1] = 1013;
  const core::Verdict v = send({105, 0, 0, 0}, 1);  // fwd() while the line is far left
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(emitted(v), (std::vector<uint8_t>{100, 0, 0, 0}));  // right()
}

TEST_F(RoverPolicy, Inv3AllowsForwardOnTheLineAndKeepsThePrefixByte) {
  const core::Verdict v = send({0x01, 105, 0, 0, 0}, 1);  // C-library framing
  EXPECT_EQ(v.decision, Decision::kAllow);
}

TEST_F(RoverPolicy, Inv2SubstitutesLeftForRightWhenTheLineIsFarRight) {
  sensors_.raw[3] = 1003;
  sensors_.raw[4] = 1004;  // pos = +15000
  const core::Verdict v = send({100, 0, 0, 0}, 1);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(emitted(v), (std::vector<uint8_t>{97, 0, 0, 0}));
}

TEST_F(RoverPolicy, AMissingSensorSampleFailsClosed) {
  sensors_.present = false;
  const core::Verdict v = send({0x46, 80, 0, 0}, 1);
  EXPECT_NE(v.decision, Decision::kAllow);
}

TEST_F(RoverPolicy, TheFourthCommandOfAJobIsIgnored) {
  EXPECT_EQ(send({0x46, 80, 0, 0}, 7).decision, Decision::kAllow);
  EXPECT_EQ(send({0x47, 80, 0, 0}, 7).decision, Decision::kAllow);
  EXPECT_EQ(send({105, 0, 0, 0}, 7).decision, Decision::kAllow);
  EXPECT_EQ(send({105, 0, 0, 0}, 7).decision, Decision::kIgnore);
  EXPECT_EQ(send({105, 0, 0, 0}, 8).decision, Decision::kAllow);  // next job
}

TEST_F(RoverPolicy, SafeStateIsStop) {
  core::Verdict v{};
  ASSERT_TRUE(checker_->safe_state(0, &v));
  EXPECT_EQ(emitted(v), (std::vector<uint8_t>{120, 0, 0, 0}));
}

TEST(CompilePolicy, RequireWithComputedFailsafeClampsTheField) {
  const char* text = R"(
device gopigo : gopigo2 at i2c-1 0x08
task t { period 100ms; wcet 1ms }
allow t -> gopigo
invariant CAP on gopigo.set_left_speed: require speed <= 120
  else failsafe speed = clamp(speed, 0, 120)
)";
  CompileOutput out;
  std::unique_ptr<core::Checker> checker;
  ASSERT_NO_FATAL_FAILURE(testing::compile_and_load("cap.policy", text, &out, &checker));
  uint8_t frame[4] = {0x46, 200, 0, 0};
  const core::Transaction tx = testing::write_tx(0, 0x08, 1, frame, sizeof frame);
  core::Verdict v{};
  checker->check(tx, &v);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.emit_bytes[1], 120);
  frame[1] = 100;
  checker->check(tx, &v);
  EXPECT_EQ(v.decision, Decision::kAllow);
}

// `require A and B` tests A, then B, when B cannot fault (the command's own
// fields and constants): the same verdicts, and a false A ends the program.
// A right side that can fault (a signal) keeps AND's meaning: a missing
// reading fails closed even when A is false.
TEST(CompilePolicy, AConjunctionTestsItsSidesInTurnUnlessTheRightOneCanFault) {
  const char* text = R"(
device gopigo : gopigo2 at i2c-1 0x08
device line : line_follower at i2c-1 0x06 sample 10ms max_age 100ms
signal pos = line_position(line.raw,
    white=[767, 815, 859, 710, 700], black=[1012, 1013, 1015, 1003, 1004],
    weights=[-100, -50, 0, 50, 100])
task t { period 100ms; wcet 1ms }
allow t -> gopigo
allow t reads line
invariant BOTH on gopigo.set_left_speed: require speed <= 120 and speed >= 10 else ignore
invariant SIGNAL on gopigo.set_right_speed: require speed <= 120 and pos > -9999 else ignore
)";
  CompileOutput out;
  std::unique_ptr<core::Checker> checker;
  ASSERT_NO_FATAL_FAILURE(testing::compile_and_load("and.policy", text, &out, &checker));
  auto check = [&](uint8_t opcode, uint8_t speed, uint64_t* steps) {
    const uint8_t frame[4] = {opcode, speed, 0, 0};
    core::Verdict v{};
    const uint64_t before = checker->executed_instructions();
    checker->check(testing::write_tx(0, 0x08, 1, frame, sizeof frame), &v);
    if (steps != nullptr) *steps = checker->executed_instructions() - before;
    return v;
  };
  uint64_t steps_false = 0, steps_true = 0;
  EXPECT_EQ(check(0x46, 200, &steps_false).decision, Decision::kIgnore);
  EXPECT_EQ(check(0x46, 5, nullptr).decision, Decision::kIgnore);
  EXPECT_EQ(check(0x46, 50, &steps_true).decision, Decision::kAllow);
  EXPECT_LT(steps_false, steps_true);  // a false left side skips the right one
  // No reading of the line sensor: the signal is unavailable, and that
  // decides (fail closed), not the left side's plain violation.
  const core::Verdict v = check(0x47, 200, nullptr);
  EXPECT_EQ(v.reason, core::Reason::kSignalUnavailable);
}

// A PCA9685 LED5 pulse as Adafruit's set_pwm writes it: registers 0x1A..0x1D
// (ON_L ON_H OFF_L OFF_H) one at a time (MODE1.AI is 0 at power-on). The
// verdict of the last write, which commits the group.
core::Verdict led5_pulse(core::Checker& checker, uint16_t task, uint16_t off, uint32_t job) {
  core::Verdict v{};
  const uint8_t regs[4][2] = {{0x1A, 0},
                              {0x1B, 0},
                              {0x1C, static_cast<uint8_t>(off & 0xFF)},
                              {0x1D, static_cast<uint8_t>(off >> 8)}};
  for (const auto& r : regs) checker.check(testing::write_tx(task, 0x40, job, r, sizeof r), &v);
  return v;
}

TEST(CompilePolicy, SequenceFollowsTheDesignTimePulses) {
  const char* text = R"(
device arm : pca9685 at i2c-1 0x40
task t { period 1s; wcet 1ms }
allow t -> arm
invariant GRIP on arm.led(5): sequence off [420, 577] else failsafe expected
)";
  CompileOutput out;
  std::unique_ptr<core::Checker> checker;
  ASSERT_NO_FATAL_FAILURE(testing::compile_and_load("arm.policy", text, &out, &checker));
  auto write_led5 = [&](uint16_t off, uint32_t job) { return led5_pulse(*checker, 0, off, job); };
  EXPECT_EQ(write_led5(420, 1).decision, Decision::kAllow);
  EXPECT_EQ(write_led5(577, 2).decision, Decision::kAllow);
  // Out of sequence: 577 again where 420 is due; the expected pulse is substituted.
  const core::Verdict v = write_led5(577, 3);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(write_led5(577, 4).decision, Decision::kAllow);  // the substitute advanced the sequence
}

// A sequence's position belongs to a run of the task by default: a session
// that ends after an odd number of moves leaves nothing to the next one (the
// 6DOF Hand's open/close across two program runs under one monitor). `scope
// task` keeps it across the task's runs, `scope device` across every task.
TEST(CompilePolicy, SequencePositionHasTheScopeThePolicyDeclares) {
  auto run_twice = [](const std::string& scope) {
    const std::string text = R"(
device arm : pca9685 at i2c-1 0x40
task t { period 1s; wcet 1ms }
task u { period 1s; wcet 1ms }
allow t -> arm
allow u -> arm
invariant GRIP on arm.led(5): sequence off [420, 577] )" +
                             scope + R"( else failsafe expected
)";
    CompileOutput out;
    std::unique_ptr<core::Checker> checker;
    EXPECT_NO_FATAL_FAILURE(testing::compile_and_load("arm.policy", text, &out, &checker));
    std::vector<Decision> got;
    if (!checker) return got;
    auto led5 = [&](uint16_t task, uint16_t off, uint32_t job) {
      got.push_back(led5_pulse(*checker, task, off, job).decision);
    };
    led5(0, 420, 1);  // first run of t: open, then its session ends
    checker->end_session(0);
    led5(1, 420, 1);  // task u: open
    led5(0, 420, 2);  // second run of t: open again
    return got;
  };
  using D = Decision;
  EXPECT_EQ(run_twice(""), (std::vector<D>{D::kAllow, D::kAllow, D::kAllow}));
  EXPECT_EQ(run_twice("scope session"), (std::vector<D>{D::kAllow, D::kAllow, D::kAllow}));
  EXPECT_EQ(run_twice("scope task"), (std::vector<D>{D::kAllow, D::kAllow, D::kFailsafe}));
  EXPECT_EQ(run_twice("scope device"), (std::vector<D>{D::kAllow, D::kFailsafe, D::kAllow}));
  CompileOutput bad = compile_source("bad.policy", R"(
device arm : pca9685 at i2c-1 0x40
task t { period 1s; wcet 1ms }
allow t -> arm
invariant GRIP on arm.led(5): sequence off [420, 577] scope forever else ignore
)");
  EXPECT_FALSE(bad.ok);
  ASSERT_EQ(bad.diagnostics.size(), 1u);
  EXPECT_EQ(bad.diagnostics[0].id, "E0301");
}

// A rate counts the commands that act: ignored or refused ones spend nothing,
// so a flood of dropped commands cannot take the task's own slots.
TEST(CompilePolicy, RateCountsOnlyCommandsThatAct) {
  const char* text = R"(
device gopigo : gopigo2 at i2c-1 0x08
task t { period 100ms; wcet 1ms }
allow t -> gopigo
limit t -> gopigo.{set_left_speed, set_right_speed} 2 per job else ignore
invariant CAP on gopigo.set_left_speed: require speed <= 120 else ignore
)";
  CompileOutput out;
  std::unique_ptr<core::Checker> checker;
  ASSERT_NO_FATAL_FAILURE(testing::compile_and_load("rate.policy", text, &out, &checker));
  auto send = [&](uint8_t cmd, uint8_t speed, uint32_t job) {
    uint8_t frame[4] = {cmd, speed, 0, 0};
    core::Verdict v{};
    checker->check(testing::write_tx(0, 0x08, job, frame, sizeof frame), &v);
    return v;
  };
  // Ten speeds the invariant drops: none of them counts.
  for (int i = 0; i < 10; ++i) EXPECT_EQ(send(0x46, 200, 1).decision, Decision::kIgnore);
  EXPECT_EQ(send(0x46, 100, 1).decision, Decision::kAllow);
  EXPECT_EQ(send(0x47, 100, 1).decision, Decision::kAllow);
  // The third that would act is over the rate; it is dropped and counts nothing either.
  const core::Verdict over = send(0x47, 100, 1);
  EXPECT_EQ(over.decision, Decision::kIgnore);
  EXPECT_EQ(over.reason, core::Reason::kRateExceeded);
  EXPECT_EQ(send(0x46, 100, 2).decision, Decision::kAllow);  // a fresh job
}

TEST(CompilePolicy, ReportsEveryErrorNotJustTheFirst) {
  const char* text = R"(
device gopigo : gopigo2 at i2c-1 0x08
task t { period 100; wcet 1ms }
allow t -> gopigo, nosuch
invariant A on gopigo: when bogus > 1 expect stop() else ignore
)";
  CompileOutput out = compile_source("many.policy", text);
  EXPECT_FALSE(out.ok);
  std::vector<std::string> ids;
  for (const auto& d : out.diagnostics) ids.push_back(d.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"E0401", "E0301", "E0301"}));
}

TEST(CompilePolicy, StrictTurnsWarningsIntoFailure) {
  const char* text = R"(
const UNUSED = 3
device gopigo : gopigo2 at i2c-1 0x08
task t { period 100ms; wcet 1ms }
allow t -> gopigo
)";
  EXPECT_TRUE(compile_source("w.policy", text).ok);
  CompileOptions strict;
  strict.strict = true;
  EXPECT_FALSE(compile_source("w.policy", text, strict).ok);
}

TEST(CompilePolicy, MoreDevicesThanTheImageHoldsIsReported) {
  std::string text = "task t { period 100ms; wcet 1ms }\n";
  for (int i = 0; i < 33; ++i) {
    text += "device d" + std::to_string(i) + " : line_follower at i2c-1 " + std::to_string(10 + i) +
            "\n";
  }
  const CompileOutput out = compile_source("big.policy", text);
  EXPECT_FALSE(out.ok);
  ASSERT_FALSE(out.diagnostics.empty());
  EXPECT_EQ(out.diagnostics.back().id, "E0508");
}

TEST(CompilePolicy, AnUnrepairedLatchCompilesToItsOwnMode) {
  const char* text = R"(
device gopigo : gopigo2 at i2c-1 0x08 {
  safe stop()
  latch after 5 unrepaired violations within 2s
}
task t { period 100ms; wcet 1ms }
allow t -> gopigo
)";
  const CompileOutput out = compile_source("l.policy", text);
  ASSERT_TRUE(out.ok);
  ASSERT_EQ(out.model.devices.size(), 1u);
  EXPECT_EQ(out.model.devices[0].record.latch_mode, core::LatchMode::kHoldSafeUnrepaired);
  EXPECT_EQ(out.model.devices[0].record.latch_count, 5);
  EXPECT_EQ(out.model.devices[0].record.latch_window_us, 2000000u);
  EXPECT_EQ(out.summary.devices[0].latch, "after 5 unrepaired violations within 2s");
}

TEST(CompilePolicy, AMaxAgeDefaultsToTwoSamplesOrTheReadersPeriod) {
  const char* text = R"(
device line : line_follower at i2c-1 0x06 sample 10ms
device other : line_follower at i2c-1 0x07 sample 30ms
task t { period 200ms; wcet 1ms }
allow t reads line
)";
  const CompileOutput out = compile_source("a.policy", text);
  ASSERT_TRUE(out.ok);
  ASSERT_EQ(out.model.devices.size(), 2u);
  EXPECT_EQ(out.model.devices[0].record.max_sample_age_us, 200000u);  // the reader's period
  EXPECT_EQ(out.model.devices[1].record.max_sample_age_us, 60000u);   // two samples
}

TEST(CompilePolicy, ATaskPhaseIsADeploymentFactBelowThePeriod) {
  const char* ok_text = "task t { period 200ms; phase 50ms; wcet 1ms }\n";
  const CompileOutput ok = compile_source("p.policy", ok_text);
  ASSERT_EQ(ok.summary.tasks.size(), 1u);
  EXPECT_EQ(ok.summary.tasks[0].phase_us, std::optional<uint32_t>(50000u));
  const CompileOutput bad =
      compile_source("p.policy", "task t { period 200ms; phase 200ms; wcet 1ms }\n");
  EXPECT_FALSE(bad.ok);
  ASSERT_FALSE(bad.diagnostics.empty());
  EXPECT_EQ(bad.diagnostics.front().id, "E0501");
}

// A device-scope sequence is the mechanism's own state: when the device's
// safe state drives the gripper open (off=420), the next move due is the
// close, whoever sent the last one. Session and task scopes are a program's
// protocol and are left alone.
TEST(CompilePolicy, ADeviceScopeSequenceGoesOnFromWhereTheSafeStateLeftIt) {
  auto after_safe_state = [](const std::string& scope, const std::string& safe) {
    const std::string text = "device arm : pca9685 at i2c-1 0x40 { safe " + safe + R"( }
task t { period 1s; wcet 1ms }
allow t -> arm
invariant GRIP on arm.led(5): sequence off [420, 577] )" +
                             scope + R"( else failsafe expected
)";
    CompileOutput out;
    std::unique_ptr<core::Checker> checker;
    EXPECT_NO_FATAL_FAILURE(testing::compile_and_load("arm.policy", text, &out, &checker));
    std::vector<Decision> got;
    if (!checker) return got;
    got.push_back(led5_pulse(*checker, 0, 420, 1).decision);  // open
    got.push_back(led5_pulse(*checker, 0, 577, 2).decision);  // close: open is due next
    core::Verdict v{};
    EXPECT_TRUE(checker->safe_state(0, &v));  // the safe state writes its led(5)
    got.push_back(led5_pulse(*checker, 0, 577, 3).decision);
    return got;
  };
  using D = Decision;
  EXPECT_EQ(after_safe_state("scope device", "led(5, on=0, off=420)"),
            (std::vector<D>{D::kAllow, D::kAllow, D::kAllow}))
      << "the safe state opened the gripper: close is due";
  EXPECT_EQ(after_safe_state("scope device", "led(5, on=0, off=577)"),
            (std::vector<D>{D::kAllow, D::kAllow, D::kFailsafe}))
      << "the safe state closed it: open is due";
  EXPECT_EQ(after_safe_state("scope device", "led(4, on=0, off=420)"),
            (std::vector<D>{D::kAllow, D::kAllow, D::kFailsafe}))
      << "another channel: the position stays";
  EXPECT_EQ(after_safe_state("scope task", "led(5, on=0, off=420)"),
            (std::vector<D>{D::kAllow, D::kAllow, D::kFailsafe}))
      << "a task's protocol is not the device's";
}

TEST(CompilePolicy, IgnoreErrnoIsAHostFactNamedLikeARejectsErrno) {
  const CompileOutput ok =
      compile_source("p.policy", "task t { period 200ms; wcet 1ms; ignore_errno EIO }\n");
  ASSERT_TRUE(ok.ok);
  ASSERT_EQ(ok.summary.tasks.size(), 1u);
  EXPECT_EQ(ok.summary.tasks[0].ignore_errno, 5);
  const CompileOutput plain = compile_source("p.policy", "task t { period 200ms; wcet 1ms }\n");
  ASSERT_TRUE(plain.ok);
  EXPECT_EQ(plain.summary.tasks[0].ignore_errno, 0) << "by default an ignored call succeeds";
  EXPECT_EQ(plain.image, ok.image) << "not part of the image: the host answers the call";
  for (const char* bad : {"task t { period 200ms; wcet 1ms; ignore_errno EWHATEVER }\n",
                          "task t { period 200ms; wcet 1ms; ignore_errno 5 }\n"}) {
    const CompileOutput out = compile_source("p.policy", bad);
    EXPECT_FALSE(out.ok) << bad;
    ASSERT_FALSE(out.diagnostics.empty()) << bad;
  }
  const CompileOutput unknown =
      compile_source("p.policy", "task t { period 200ms; wcet 1ms; ignore_errno EWHATEVER }\n");
  ASSERT_FALSE(unknown.diagnostics.empty());
  EXPECT_EQ(unknown.diagnostics.front().id, "E0608");
}

}  // namespace
}  // namespace contego::policy
