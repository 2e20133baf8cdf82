// Policies over the PCA9685 profile, compiled and run by the trusted core:
// per-channel history, per-channel safe states, the shadow after ALL_LED
// writes, `failsafe expected` over a stale shadow and the general call.
// Each test states the behaviour docs/core.md and docs/policy-language.md
// promise, so a regression in the compiler or the core shows up here.
#include <gtest/gtest.h>
#include <memory>
#include <string>
#include <vector>

#include "contego/core/checker.h"

#include "image/image_model.h"
#include "policy/compile.h"
#include "policy/test_util.h"

namespace contego::policy {
namespace {

using core::Decision;
using core::Reason;

// LEDn registers: ON_L ON_H OFF_L OFF_H at 0x06 + 4n.
constexpr uint8_t led_reg(uint8_t channel) { return static_cast<uint8_t>(0x06 + 4 * channel); }

// The arm and a task `t` that may drive it, then `rules`.
std::string with_arm(const std::string& rules) {
  return "device arm : pca9685 at i2c-1 0x40\n"
         "task t { period 1s; wcet 1ms }\n"
         "allow t -> arm\n" +
         rules + "\n";
}

// (register, value) pairs.
using Pairs = std::vector<std::pair<uint8_t, uint8_t>>;

class Pca9685Policy : public ::testing::Test {
 protected:
  // Compiles `text` (a policy declaring `device arm : pca9685 at i2c-1 0x40`) and loads it.
  void load(const std::string& text) {
    ASSERT_NO_FATAL_FAILURE(testing::compile_and_load("arm.policy", text, &out_, &checker_));
  }

  core::Verdict write(std::vector<uint8_t> bytes, uint32_t job, uint16_t addr = 0x40,
                      uint16_t task = 0) {
    const core::Transaction tx =
        testing::write_tx(task, addr, job, bytes.data(), bytes.size(), now_us_ += 1000);
    core::Verdict v{};
    checker_->check(tx, &v);
    return v;
  }

  // Byte-wise write of one channel (MODE1.AI is 0 at power-on), as the
  // Adafruit library does; returns the verdict of the committing write.
  core::Verdict write_led(uint8_t channel, uint16_t on, uint16_t off, uint32_t job,
                          uint16_t task = 0) {
    const uint8_t r = led_reg(channel);
    write({r, static_cast<uint8_t>(on & 0xFF)}, job, 0x40, task);
    write({static_cast<uint8_t>(r + 1), static_cast<uint8_t>(on >> 8)}, job, 0x40, task);
    write({static_cast<uint8_t>(r + 2), static_cast<uint8_t>(off & 0xFF)}, job, 0x40, task);
    return write({static_cast<uint8_t>(r + 3), static_cast<uint8_t>(off >> 8)}, job, 0x40, task);
  }
  // The register writes that replace led(5, on, off=577), a pulse out of the
  // gripper's sequence (the invariant answers `failsafe expected`).
  Pairs substituted_for_grip(uint16_t on, uint32_t job) {
    const core::Verdict v = write_led(5, on, 577, job);
    EXPECT_EQ(v.decision, Decision::kFailsafe);
    return pairs(v);
  }

  // The (register, value) pairs a verdict writes.
  static Pairs pairs(const core::Verdict& v) {
    Pairs p;
    uint32_t at = 0;
    for (uint32_t i = 0; i < v.emit_count; ++i) {
      if (v.emit_len[i] == 2) p.emplace_back(v.emit_bytes[at], v.emit_bytes[at + 1]);
      at += v.emit_len[i];
    }
    return p;
  }

  CompileOutput out_;
  std::unique_ptr<core::Checker> checker_;
  uint64_t now_us_ = 0;
};

// --- LAST_FIELD history per channel --------------------------------------------

TEST_F(Pca9685Policy, LastFieldIsTheSameChannelsLastValueNotAnotherChannels) {
  load(with_arm(
      "invariant STEP on arm.led: require abs(off - last(off)) <= 50 else failsafe off = 375"));
  // No history for a channel yet: last() faults, the rule fails closed with
  // its constant substitute, and the substitute becomes the channel's history.
  EXPECT_EQ(write_led(3, 0, 300, 1).decision, Decision::kFailsafe);  // channel 3 := 375
  EXPECT_EQ(write_led(5, 0, 600, 2).decision, Decision::kFailsafe);  // channel 5 := 375
  EXPECT_EQ(write_led(5, 0, 400, 3).decision, Decision::kAllow);     // channel 5: 375 -> 400
  // Channel 3's last value is its own 375, not channel 5's 400: a step of 35 is fine.
  EXPECT_EQ(write_led(3, 0, 340, 4).decision, Decision::kAllow);
  // And channel 5 still remembers 400: a step to 340 (60) is too big.
  EXPECT_EQ(write_led(5, 0, 340, 5).decision, Decision::kFailsafe);
}

// --- per-channel safe states (TemplateRecord::index) -----------------------------

TEST_F(Pca9685Policy, SafeStateWritesEachNamedChannelWithEveryField) {
  load(R"(
device arm : pca9685 at i2c-1 0x40 { safe led(5, on=0, off=420), led(0, off=375) }
task t { period 1s; wcet 1ms }
allow t -> arm
)");
  core::Verdict v{};
  ASSERT_TRUE(checker_->safe_state(0, &v));
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.addr, 0x40);
  // Channel 5 then channel 0; unnamed fields are 0, so the power-on full-off
  // bit (LEDn_OFF_H bit 4) is cleared: the servo is driven, not left limp.
  EXPECT_EQ(pairs(v), (Pairs{{0x1A, 0x00},
                             {0x1B, 0x00},
                             {0x1C, 0xA4},
                             {0x1D, 0x01},
                             {0x06, 0x00},
                             {0x07, 0x00},
                             {0x08, 0x77},
                             {0x09, 0x01}}));
}

TEST_F(Pca9685Policy, SafeStateOfARepeatedGroupMustNameItsChannel) {
  const CompileOutput out = compile_source("arm.policy", R"(
device arm : pca9685 at i2c-1 0x40 { safe led(off=375) }
task t { period 1s; wcet 1ms }
allow t -> arm
)");
  ASSERT_FALSE(out.ok);
  ASSERT_FALSE(out.diagnostics.empty());
  EXPECT_NE(out.diagnostics[0].rendered.find("E0309"), std::string::npos)
      << out.diagnostics[0].rendered;
}

TEST_F(Pca9685Policy, TheVerifierRefusesAChannelTheCommandDoesNotHave) {
  load(R"(
device arm : pca9685 at i2c-1 0x40 { safe led(5, off=420) }
task t { period 1s; wcet 1ms }
allow t -> arm
)");
  image::ImageModel m = out_.model;
  ASSERT_EQ(m.templates.size(), 1u);
  m.templates[0].index = 16;  // led has channels 0..15
  std::vector<uint8_t> bad = image::serialize(m);
  core::Checker c;
  EXPECT_EQ(c.load(bad.data(), static_cast<uint32_t>(bad.size())).status,
            core::LoadStatus::kBadField);
  m.templates[0].index = core::kSameIndex;  // a safe state has no checked command
  bad = image::serialize(m);
  EXPECT_EQ(c.load(bad.data(), static_cast<uint32_t>(bad.size())).status,
            core::LoadStatus::kBadField);
}

TEST_F(Pca9685Policy, LatchingDrivesThePerChannelSafeStateAndHoldsIt) {
  load(R"(
device arm : pca9685 at i2c-1 0x40 {
  safe led(5, on=0, off=420)
  latch after 2 violations within 1s
}
task t { period 1s; wcet 1ms }
allow t -> arm
invariant WINDOW on arm.led: require off <= 600 else ignore
)");
  EXPECT_EQ(write_led(2, 0, 900, 1).decision, Decision::kIgnore);
  const core::Verdict v = write_led(2, 0, 900, 2);  // the second violation latches
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kLatched);
  EXPECT_EQ(pairs(v), (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x01}}));
  EXPECT_TRUE(checker_->latched(0));
  EXPECT_EQ(write_led(2, 0, 300, 3).reason, Reason::kLatched);  // held until reset
}

TEST_F(Pca9685Policy, AConstantFailsafeCommandCanNameAnotherChannel) {
  load(
      with_arm("invariant ALL on arm.all_led: require full_on == 0 else failsafe led(5, off=420)"));
  // ALL_LED_ON_H = 0x10 (every output constantly on) becomes gripper-open on channel 5.
  write({0xFA, 0x00}, 1);
  write({0xFB, 0x10}, 1);
  write({0xFC, 0x00}, 1);
  const core::Verdict v = write({0xFD, 0x00}, 1);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(pairs(v), (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x01}}));
}

// --- the shadow after ALL_LED writes, `failsafe expected` ------------------------

const std::string kGrip =
    with_arm("invariant GRIP on arm.led(5): sequence off [420, 577] else failsafe expected");

TEST_F(Pca9685Policy, AllLedWritesReachEveryChannelsShadow) {
  load(kGrip);
  // At power-on LED5_OFF_H = 0x10 (full off). ALL_LED_OFF_H = 0x00 clears the
  // full-off bit of every channel on the device; the shadow must follow.
  EXPECT_EQ(write({0xFC, 0x00}, 1).decision, Decision::kAllow);
  EXPECT_EQ(write({0xFD, 0x00}, 1).decision, Decision::kAllow);
  // Out of sequence (577 where 420 is due): the expected pulse is substituted;
  // its unnamed fields come from the shadow, which now says "not full off".
  EXPECT_EQ(substituted_for_grip(0, 2),
            (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x01}}));
}

TEST_F(Pca9685Policy, AllLedBroadcastIsUndoneWhenItsTransactionIsRefused) {
  load(
      with_arm("invariant ALL on arm.all_led: require off <= 600 else ignore\n"
               "invariant GRIP on arm.led(5): sequence off [420, 577] else failsafe expected"));
  // ALL_LED_OFF = 0x0FFF is ignored: nothing reached the device, so channel 5's
  // shadow keeps its power-on OFF_H (0x10) and the substitute says so too.
  write({0xFC, 0xFF}, 1);
  EXPECT_EQ(write({0xFD, 0x0F}, 1).decision, Decision::kIgnore);
  EXPECT_EQ(substituted_for_grip(0, 2),
            (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x11}}));
}

TEST_F(Pca9685Policy, FailsafeExpectedNeverTakesUnnamedFieldsFromTheRequest) {
  load(kGrip);
  // The attacker's write sets full_on with a wrong pulse. The substitute takes
  // the fields the invariant does not name from the shadow (what the device
  // holds: here its power-on state, full off), never from the request, so the
  // attacker's full-on bit cannot ride along with the expected pulse.
  EXPECT_EQ(substituted_for_grip(0x1000, 1),
            (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x11}}));
}

TEST_F(Pca9685Policy, FailsafeExpectedAfterTheSafeStateDrivesTheChannel) {
  // The monitor writes the safe state on start: it names every field of
  // channel 5, so from then on the shadow of that channel is exact and a
  // substitute drives the gripper instead of keeping the power-on full-off bit.
  load(std::string(R"(
device arm : pca9685 at i2c-1 0x40 { safe led(5, on=0, off=420) }
task t { period 1s; wcet 1ms }
allow t -> arm
invariant GRIP on arm.led(5): sequence off [420, 577] else failsafe expected
)"));
  core::Verdict safe{};
  ASSERT_TRUE(checker_->safe_state(0, &safe));
  EXPECT_EQ(substituted_for_grip(0, 1),
            (Pairs{{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x01}}));
}

// --- the general call -------------------------------------------------------------

TEST_F(Pca9685Policy, SoftwareResetIsACommandAPolicyCanDeny) {
  load(R"(
device arm : pca9685 at i2c-1 0x40
task init { period 1s; wcet 1ms }
task gripper { period 1s; wcet 1ms }
allow init -> arm
allow gripper -> arm
limit gripper -> arm.swrst 0 per job else reject EPERM
)");
  const core::Verdict denied = write({0x06}, 1, 0x00, /*task=*/1);
  EXPECT_EQ(denied.decision, Decision::kReject);
  EXPECT_EQ(denied.reason, Reason::kRateExceeded);
  EXPECT_EQ(denied.emit_count, 0);
  // The init task may reset: the byte goes to the general-call address, and
  // the shadow returns to power-on (LED5_OFF_H = 0x10 again).
  write_led(5, 0, 420, 1);
  const core::Verdict reset = write({0x06}, 2, 0x00, /*task=*/0);
  EXPECT_EQ(reset.decision, Decision::kAllow);
  EXPECT_EQ(reset.addr, 0x00);
  ASSERT_EQ(reset.emit_count, 1);
  EXPECT_EQ(reset.emit_bytes[0], 0x06);
  // Another general-call byte is no command of the profile.
  EXPECT_EQ(write({0x04}, 3, 0x00).reason, Reason::kUnknownCommand);
}

TEST_F(Pca9685Policy, ARegisterWriteThroughTheGeneralCallIsIgnored) {
  load(with_arm("invariant CAP on arm.led: require off <= 600 else failsafe off = 600"));
  // A PCA9685 takes a general call's first byte as a command (0x06: software
  // reset), never as a register: a channel write sent there is no write the
  // policy can check, whatever its values. Nothing is written, nothing of
  // the model changes.
  ASSERT_EQ(write({0x00, 0x21}, 1).decision, Decision::kAllow);
  for (const std::vector<uint8_t>& bytes :
       {std::vector<uint8_t>{led_reg(2), 0x00, 0x00, 0x84, 0x03},     // off = 900
        std::vector<uint8_t>{led_reg(0), 0x00, 0x00, 0x2C, 0x01}}) {  // `06 ...` = SWRST
    const core::Verdict v = write(bytes, 2, 0x00);
    EXPECT_EQ(v.decision, Decision::kIgnore);
    EXPECT_EQ(v.reason, Reason::kGeneralCall);
    EXPECT_EQ(v.emit_count, 0);
  }
  uint8_t mode1 = 0;
  ASSERT_TRUE(checker_->shadow(0, 0x00, &mode1));
  EXPECT_EQ(mode1, 0x21);
}

}  // namespace
}  // namespace contego::policy
