// Register-map decoding on the PCA9685-like arm: staging of byte writes,
// word and auto-increment block writes, several groups per transaction,
// templates encoded as register pairs, aliases, state words.
#include <gtest/gtest.h>

#include "core/harness_fixture_test.h"
#include "core/test_fixtures.h"

namespace contego::core {
namespace {

using namespace testing::arm_tests;  // NOLINT(google-build-using-namespace)

class ArmTest : public testing::HarnessTest {
 protected:
  void SetUp() override { load(arm::model()); }
  Verdict send(Bytes bytes, uint16_t task = arm::kController, uint16_t addr = kAddr) {
    return h.check(task, addr, std::move(bytes), ++now);
  }
  void auto_increment_on() { ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x21)); }
  uint64_t now = 1000;
};

TEST_F(ArmTest, ByteWiseWritesStageUntilOffHighThenCommitOnce) {
  // set_pwm(5, 0, 420) as the Adafruit library sends it: four 2-byte writes.
  for (Bytes w : {Bytes{kLed5, 0x00}, Bytes{kLed5 + 1, 0x00}, Bytes{kLed5 + 2, 0xA4}}) {
    const Verdict v = send(w);
    EXPECT_EQ(v.decision, Decision::kAllow);
    EXPECT_EQ(v.reason, Reason::kStaged);
    EXPECT_EQ(v.emit_count, 0);
  }
  ASSERT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStaged);
  const Verdict commit = send({kLed5 + 3, 0x01});
  EXPECT_EQ(commit.decision, Decision::kAllow);
  EXPECT_EQ(commit.reason, Reason::kAllowed);
  EXPECT_EQ(emits(commit),
            (Writes{{kLed5, 0x00}, {kLed5 + 1, 0x00}, {kLed5 + 2, 0xA4}, {kLed5 + 3, 0x01}}));
  ASSERT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].command, arm::kLed);
  EXPECT_EQ(h.audits[0].index, 5);
  EXPECT_EQ(h.audits[0].fields[1], 420);
  // The staging is consumed: OFF_H alone now commits with the shadow values.
  const Verdict again = send({kLed5 + 3, 0x02});  // off = 0x2A4 = 676: out of range
  EXPECT_EQ(again.decision, Decision::kFailsafe);
}

TEST_F(ArmTest, AStagedGroupEndsWithItsSessionAndIsCounted) {
  // OFF_L of LED5 staged by a program that then exits: the write never
  // reached the device, and the next run's OFF_H must not complete it.
  EXPECT_EQ(send({kLed5 + 2, 0xA4}).reason, Reason::kStaged);
  EXPECT_EQ(h.checker->end_session(arm::kOther), 0u);  // not its staging
  EXPECT_EQ(h.checker->end_session(arm::kController), 1u);
  EXPECT_EQ(h.checker->end_session(arm::kController), 0u);
  // Completed with the dropped OFF_L the pulse would be 0x1A4 = 420 (allowed);
  // with the shadow's OFF_L (0) it is 0x100 = 256, outside the range.
  const Verdict v = send({kLed5 + 3, 0x01});
  EXPECT_EQ(v.reason, Reason::kInvariantViolated);
  ASSERT_FALSE(h.audits.empty());
  EXPECT_EQ(h.audits.back().fields[1], 0x100);
}

TEST_F(ArmTest, WordWriteStagesLowAndCommitsInOneTransaction) {
  auto_increment_on();
  const Verdict v = send({kLed5 + 2, 0xA4, 0x01});  // WORD_DATA: OFF_L, OFF_H = 420
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (Writes{{kLed5 + 2, 0xA4}, {kLed5 + 3, 0x01}}));
}

TEST_F(ArmTest, AutoIncrementBlockSpanningGroupsChecksEveryCommand) {
  auto_increment_on();
  // Channels 0 and 1: on = 0, off = 300 and 400.
  const Verdict v = send({0x06, 0, 0, 0x2C, 0x01, 0, 0, 0x90, 0x01});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(v.emit_count, 8);
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].index, 0);
  EXPECT_EQ(h.audits[0].fields[1], 300);
  EXPECT_EQ(h.audits[1].index, 1);
  EXPECT_EQ(h.audits[1].fields[1], 400);
  // One bad channel in the block rejects nothing by itself (failsafe), but a
  // forbidden register anywhere rejects the whole transaction.
  const Verdict mixed = send({0x06, 0, 0, 0x2C, 0x01, 0, 0, 0xFF, 0x0F});  // ch1 off = 4095
  EXPECT_EQ(mixed.decision, Decision::kFailsafe);
  EXPECT_EQ(mixed.reason, Reason::kInvariantViolated);
  // ch0 as written, ch1 replaced by the template (off = 375 = 0x177)
  EXPECT_EQ(emits(mixed), (Writes{{0x06, 0},
                                  {0x07, 0},
                                  {0x08, 0x2C},
                                  {0x09, 0x01},
                                  {0x0A, 0},
                                  {0x0B, 0},
                                  {0x0C, 0x77},
                                  {0x0D, 0x01}}));
}

TEST_F(ArmTest, WithoutAutoIncrementAllBytesGoToOneRegister) {
  // MODE1 = 0x11 at power-on: AI clear. Two data bytes both land in OFF_H of
  // channel 0, so the group commits twice (off = 0x100, then 0x200).
  const Verdict v = send({0x09, 0x01, 0x02});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (Writes{{0x09, 0x01}, {0x09, 0x02}}));
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].fields[1], 256);
  EXPECT_EQ(h.audits[1].fields[1], 512);
}

TEST_F(ArmTest, AutoIncrementFollowsTheShadowOfMode1) {
  EXPECT_EQ(send({0x00, 0x21}).decision, Decision::kAllow);  // MODE1: AI on, SLEEP off
  const Verdict v = send({kLed5 + 2, 0xA4, 0x01});
  EXPECT_EQ(emits(v), (Writes{{kLed5 + 2, 0xA4}, {kLed5 + 3, 0x01}}));
}

TEST_F(ArmTest, RangeViolationSubstitutesTheWholeGroupFromTheShadow) {
  h.checker->seed_register(arm::kArm, kLed5, 0x10);  // ON_L as the device holds it
  const Verdict v = send({kLed5 + 3, 0x0F});         // off = 0xF00: out of range
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.rule, arm::kRange);
  EXPECT_EQ(emits(v),
            (Writes{{kLed5, 0x10}, {kLed5 + 1, 0}, {kLed5 + 2, 0x77}, {kLed5 + 3, 0x01}}));
  ASSERT_EQ(h.audit_substitutes.size(), 1u);
  EXPECT_EQ(h.audit_substitutes[0].size(), 8u);
}

TEST_F(ArmTest, UnknownAndForbiddenRegistersAreRejected) {
  Verdict v = send({0x50, 0x01});  // reserved
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kUnknownCommand);
  v = send({0xFF, 0x01});  // TestMode
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kForbiddenCommand);
  auto_increment_on();
  v = send({0xFE, 0x65, 0x00});  // PRE_SCALE then wraps past the map
  EXPECT_EQ(v.decision, Decision::kReject);
}

TEST_F(ArmTest, RegisterPointerWriteIsARead) {
  EXPECT_EQ(send({0x00}, arm::kOther).decision, Decision::kAllow);
  const Verdict v = send({0x00}, arm::kController);
  EXPECT_EQ(emits(v), (Writes{{0x00}}));
}

TEST_F(ArmTest, AllCallAliasIsCheckedAsTheArmAndEmittedToItsAddress) {
  const Verdict v = send({0x00, 0x31}, arm::kController, 0x70);
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(v.device, arm::kArm);
  EXPECT_EQ(v.addr, kAddr);
  EXPECT_EQ(send({0x00, 0x31}, arm::kOther, 0x70).reason, Reason::kAccessDenied);
}

TEST_F(ArmTest, GeneralCallChecksEveryListener) {
  // SWRST (general call, one byte 0x06) is not a register-pointer write.
  const Verdict swrst = send({0x06}, arm::kController, 0x00);
  EXPECT_NE(swrst.decision, Decision::kAllow);
  EXPECT_EQ(swrst.emit_count, 0);
  // A register write through the general call is no command any device takes
  // as such (a PCA9685 reads `06 ...` as a software reset): ignored.
  const Verdict mode2 = send({0x01, 0x04}, arm::kController, 0x00);
  EXPECT_EQ(mode2.decision, Decision::kIgnore);
  EXPECT_EQ(mode2.reason, Reason::kGeneralCall);
  EXPECT_EQ(mode2.emit_count, 0);
}

TEST_F(ArmTest, AGeneralCallsFailSafeIsWrittenToTheListenersOwnAddress) {
  // A software reset (general-call command 0x06) the controller may not send:
  // the rate rule's template (MODE1 = 0x11) goes to the arm's address, and
  // nothing to the general call.
  image::ImageModel m = arm::model();
  image::Named<CommandRecord> swrst;
  swrst.name = "swrst";
  swrst.record.device = arm::kArm;
  swrst.record.command_class = CommandClass::kActuate;
  swrst.record.match = 0x06;
  testing::add_command(m, swrst, {});
  m.devices[arm::kArm].record.command_count = 7;
  image::Named<RateRecord> rate;
  rate.name = "no_reset";
  rate.record.task = arm::kController;
  rate.record.device = arm::kArm;
  rate.record.max_per_job = 0;
  rate.record.commands = testing::mask_of({6});
  rate.record.response = Response::kFailsafe;
  rate.record.template_id = arm::kTplSafe;
  m.rates.push_back(rate);
  load(m);
  const Verdict v = send({0x06}, arm::kController, 0x00);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kRateExceeded);
  EXPECT_EQ(v.addr, kAddr);
  EXPECT_EQ(emits(v), (Writes{{0x00, 0x11}}));
}

TEST_F(ArmTest, StagingConflictDropsTheOtherTasksBytes) {
  image::ImageModel m = arm::model();
  m.access[arm::kOther].actuate_devices = 1u << arm::kArm;
  load(m);
  EXPECT_EQ(send({kLed4 + 2, 0xA4}, arm::kController).reason, Reason::kStaged);
  send({kLed4 + 2, 0x41}, arm::kOther);
  ASSERT_GE(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagingConflict);
  EXPECT_EQ(h.audits[0].task, arm::kController);
  // The other task's OFF_L (0x41) is what commits with OFF_H 0x02: 577.
  const Verdict v = send({kLed4 + 3, 0x02}, arm::kOther);
  EXPECT_EQ(emits(v), (Writes{{kLed4 + 2, 0x41}, {kLed4 + 3, 0x02}}));
}

TEST_F(ArmTest, AWriteThatDoesNotActLeavesTheOtherTasksStagingAndNoRecord) {
  // The other task may not actuate the arm: its OFF_L is refused, so the
  // controller's staged OFF_L is neither dropped nor said to be.
  EXPECT_EQ(send({kLed4 + 2, 0xA4}, arm::kController).reason, Reason::kStaged);
  const Verdict refused = send({kLed4 + 2, 0x41}, arm::kOther);
  EXPECT_EQ(refused.decision, Decision::kReject);
  ASSERT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].task, arm::kOther);
  EXPECT_NE(h.audits[0].reason, Reason::kStagingConflict);
  const Verdict v = send({kLed4 + 3, 0x01}, arm::kController);  // 0x1A4 = 420
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (Writes{{kLed4 + 2, 0xA4}, {kLed4 + 3, 0x01}}));
}

TEST_F(ArmTest, AGroupTheTaskLeavesIncompleteIsDroppedAndAudited) {
  // LED4's OFF_L alone, then LED5: LED4's write never reaches the device,
  // and the record says so when the task moves on, not never.
  EXPECT_EQ(send({kLed4 + 2, 0xA4}).reason, Reason::kStaged);
  EXPECT_EQ(send({kLed5, 0x00}).reason, Reason::kStaged);
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagedIncomplete);
  EXPECT_EQ(h.audits[0].decision, Decision::kIgnore);
  EXPECT_EQ(h.audits[0].task, arm::kController);
  EXPECT_EQ(h.audits[0].command, arm::kLed);
  EXPECT_EQ(h.audits[0].index, 4);
  EXPECT_EQ(h.audits[1].reason, Reason::kStaged);
  // LED4's OFF_H alone commits the shadow's OFF_L (0): 0x100 = 256; and it
  // leaves LED5's ON_L behind in turn.
  send({kLed4 + 3, 0x01});
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagedIncomplete);
  EXPECT_EQ(h.audits[0].index, 5);
  EXPECT_EQ(h.audits[1].fields[1], 0x100);
  // Registers of the group being written never count as left behind.
  EXPECT_EQ(send({kLed5, 0x00}).reason, Reason::kStaged);
  EXPECT_EQ(send({kLed5 + 1, 0x00}).reason, Reason::kStaged);
  EXPECT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.checker->end_session(arm::kController), 2u);
}

TEST_F(ArmTest, AStagedRegisterWrittenAgainSaysItsEarlierByteNeverActed) {
  // Adafruit's CircuitPython driver writes a pulse as one 5-byte write; with
  // auto-increment off all four bytes land in LED5_ON_L, held. The second
  // such write says at once that the first never reached the chip.
  const Bytes pulse{kLed5, 0x00, 0x00, 0xA4, 0x01};
  EXPECT_EQ(send(pulse).reason, Reason::kStaged);
  EXPECT_EQ(h.audits.size(), 1u);
  const Verdict again = send(pulse);
  EXPECT_EQ(again.decision, Decision::kAllow);
  EXPECT_EQ(again.reason, Reason::kStaged);
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagedIncomplete);
  EXPECT_EQ(h.audits[0].decision, Decision::kIgnore);
  EXPECT_EQ(h.audits[0].task, arm::kController);
  EXPECT_EQ(h.audits[0].command, arm::kLed);
  EXPECT_EQ(h.audits[0].index, 5);
  EXPECT_EQ(h.audits[1].reason, Reason::kStaged);
  // The group completes with the byte written last.
  send({kLed5 + 1, 0x00});
  send({kLed5 + 2, 0xA4});
  EXPECT_EQ(emits(send({kLed5 + 3, 0x01})),
            (Writes{{kLed5, 0x01}, {kLed5 + 1, 0x00}, {kLed5 + 2, 0xA4}, {kLed5 + 3, 0x01}}));
  EXPECT_EQ(h.checker->end_session(arm::kController), 0u);
}

TEST_F(ArmTest, AnAbortedTransferDoesNotBringBackAByteItsWriteDropped) {
  // A rewrite that does not act (another message of its transfer refused)
  // has its record already: the byte it said dropped stays dropped.
  EXPECT_EQ(send({kLed5, 0x05}).reason, Reason::kStaged);
  h.checker->begin_transfer();
  send({kLed5, 0x06});
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagedIncomplete);
  h.checker->abort_transfer(Decision::kReject);
  // Neither byte is staged: the earlier was said dropped, the later did not act.
  EXPECT_EQ(h.checker->end_session(arm::kController), 0u);
}

TEST_F(ArmTest, ARegisterOfAGroupTheTaskCannotSendIsDecidedAtOnce) {
  // No actuate access: refused with the rule's errno on its first byte, not
  // held as "allowed (staged)" for a last register that never comes.
  const Verdict v = send({kLed4 + 2, 0xA4}, arm::kOther);
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kAccessDenied);
  EXPECT_EQ(h.checker->end_session(arm::kOther), 0u);
  // A limit of 0 per job on the group answers its first byte with the limit's response.
  image::ImageModel m = arm::model();
  image::Named<RateRecord> none;
  none.name = "no_all_led";
  none.record.task = arm::kController;
  none.record.device = arm::kArm;
  none.record.max_per_job = 0;
  none.record.commands = testing::mask_of({arm::kAllLed});
  none.record.response = Response::kIgnore;
  none.record.template_id = kNone;
  m.rates.push_back(none);
  load(m);
  const Verdict w = send({0xFB, 0x10});  // ALL_LED_ON_H: every channel full on
  EXPECT_EQ(w.decision, Decision::kIgnore);
  EXPECT_EQ(w.reason, Reason::kRateExceeded);
  EXPECT_EQ(h.checker->end_session(arm::kController), 0u);
  // Groups the limit does not select still stage.
  EXPECT_EQ(send({kLed5 + 2, 0xA4}).reason, Reason::kStaged);
}

TEST_F(ArmTest, APrescaleTheChipWouldDropIsNotSentAndNotShadowed) {
  // PRE_SCALE only while MODE1 SLEEP (bit 4) stops the oscillator, as the PCA9685.
  image::ImageModel m = arm::model();
  m.devices[0].record.gated = arm::kPrescale + 1;
  m.devices[0].record.gate_bit = 4;
  load(m);
  ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x01));  // awake
  ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0xFE, 0x79));  // 50 Hz
  const Verdict awake = send({0xFE, 0x65});
  EXPECT_EQ(awake.decision, Decision::kIgnore);
  EXPECT_EQ(awake.reason, Reason::kNotTaken);
  EXPECT_EQ(awake.emit_count, 0);
  uint8_t v = 0;
  ASSERT_TRUE(h.checker->shadow(arm::kArm, 0xFE, &v));
  EXPECT_EQ(v, 0x79);  // what the chip still holds
  // Asleep (the vendor's set_pwm_freq: sleep, prescale, wake): taken.
  ASSERT_EQ(send({0x00, 0x11}).decision, Decision::kAllow);
  const Verdict asleep = send({0xFE, 0x65});
  EXPECT_EQ(asleep.decision, Decision::kAllow);
  EXPECT_EQ(emits(asleep), (Writes{{0xFE, 0x65}}));
  ASSERT_TRUE(h.checker->shadow(arm::kArm, 0xFE, &v));
  EXPECT_EQ(v, 0x65);
  // A task that may not drive the chip is refused for that, not told "not taken".
  ASSERT_EQ(send({0x00, 0x01}).decision, Decision::kAllow);
  EXPECT_EQ(send({0xFE, 0x65}, arm::kOther).reason, Reason::kAccessDenied);
  // Nor one whose limit on it is spent: the limit answers, with its errno.
  image::Named<RateRecord> none;
  none.name = "no_prescale";
  none.record.task = arm::kController;
  none.record.device = arm::kArm;
  none.record.max_per_job = 0;
  none.record.commands = testing::mask_of({arm::kPrescale});
  none.record.response = Response::kReject;
  none.record.reply_errno = 1;  // EPERM
  none.record.template_id = kNone;
  m.rates.push_back(none);
  load(m);
  ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x01));
  const Verdict limited = send({0xFE, 0x65});
  EXPECT_EQ(limited.reason, Reason::kRateExceeded);
  EXPECT_EQ(limited.reply_errno, 1);
}

TEST_F(ArmTest, RejectedTransactionLeavesNoStagedBytes) {
  auto_increment_on();
  // ch15 OFF_L, OFF_H (commits off = 0x201), then reserved 0x46: all refused.
  const Verdict v = send({0x44, 0x01, 0x02, 0x03});
  EXPECT_EQ(v.decision, Decision::kReject);
  // ch15 OFF_H alone now commits from the shadow (zeros), not from 0x01/0x02/0x03.
  const Verdict c = send({0x45, 0x00});
  EXPECT_EQ(emits(c), (Writes{{0x45, 0x00}}));
}

TEST_F(ArmTest, SequenceStateCommitsOnlyWhenTheTransactionWrites) {
  auto_increment_on();
  Verdict v = send({kLed5, 0, 0, 0xA4, 0x01});  // 420: step 0 -> 1
  ASSERT_EQ(v.decision, Decision::kAllow);
  // AI off: OFF_L = 0x41 staged, then OFF_H written twice in one transaction.
  // The first commit (577) passes step 1 and sets a pending step 0; the
  // second (577 again) fails step 0, so the whole transaction is rejected and
  // the pending step is discarded.
  h.checker->seed_register(arm::kArm, 0x00, 0x01);
  EXPECT_EQ(send({kLed5 + 2, 0x41}).reason, Reason::kStaged);
  v = send({kLed5 + 3, 0x02, 0x02});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.rule, arm::kSequence);
  EXPECT_EQ(v.reply_errno, 1);
  EXPECT_EQ(v.emit_count, 0);
  // Still at step 1: 577 passes now, then 577 again does not.
  auto_increment_on();
  EXPECT_EQ(send({kLed5, 0, 0, 0x41, 0x02}).decision, Decision::kAllow);
  EXPECT_EQ(send({kLed5, 0, 0, 0x41, 0x02}).decision, Decision::kReject);
}

TEST_F(ArmTest, SafeStateIsWrittenAsRegisterPairs) {
  Verdict v{};
  ASSERT_TRUE(h.checker->safe_state(arm::kArm, &v));
  EXPECT_EQ(emits(v), (Writes{{0x00, 0x11}}));
  EXPECT_EQ(v.addr, kAddr);
}

// A preview (apply false) writes the same bytes and moves nothing: neither
// the shadow the safe state writes nor the sequence position it sets.
TEST_F(ArmTest, APreviewOfTheSafeStateLeavesTheModelAsItWas) {
  auto m = arm::model();
  m.invariants[arm::kSequence].record.after_safe = 2;  // step 1 (577 next) after it
  load(m);
  ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x21));
  Verdict preview{};
  ASSERT_TRUE(h.checker->safe_state(arm::kArm, &preview, false));
  EXPECT_EQ(emits(preview), (Writes{{0x00, 0x11}}));
  uint8_t mode1 = 0;
  ASSERT_TRUE(h.checker->shadow(arm::kArm, 0x00, &mode1));
  EXPECT_EQ(mode1, 0x21);
  EXPECT_EQ(send({kLed5, 0, 0, 0xA4, 0x01}).decision, Decision::kAllow);  // 420: step 0 -> 1
  EXPECT_EQ(send({kLed5, 0, 0, 0x41, 0x02}).decision, Decision::kAllow);  // 577: step 1 -> 0
  Verdict applied{};
  ASSERT_TRUE(h.checker->safe_state(arm::kArm, &applied));
  EXPECT_EQ(emits(applied), emits(preview));
  ASSERT_TRUE(h.checker->shadow(arm::kArm, 0x00, &mode1));
  EXPECT_EQ(mode1, 0x11);
  ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x21));
  EXPECT_EQ(send({kLed5, 0, 0, 0xA4, 0x01}).decision, Decision::kReject);  // at step 1 now
}

// What a host reads back to seed the shadow: every register of every group
// (MODE1, MODE2, 16 LED groups of 4, ALL_LED, PRE_SCALE, TEST_MODE), each once.
TEST_F(ArmTest, CommandRegistersListEveryGroupsRegistersOnce) {
  uint8_t regs[kMaxRegisters];
  const uint32_t n = h.checker->command_registers(arm::kArm, regs);
  ASSERT_EQ(n, 2u + 64u + 4u + 2u);
  EXPECT_EQ(regs[0], 0x00);
  EXPECT_EQ(regs[1], 0x01);
  EXPECT_EQ(regs[2], 0x06);
  EXPECT_EQ(regs[2 + 63], 0x45);
  EXPECT_EQ(regs[2 + 64], 0xFA);
  EXPECT_EQ(regs[n - 1], 0xFF);
  for (uint32_t i = 1; i < n; ++i) EXPECT_LT(regs[i - 1], regs[i]);
  EXPECT_EQ(h.checker->command_registers(5, regs), 0u);
  Harness rover;
  ASSERT_EQ(rover.load(testing::rover::model()).status, LoadStatus::kOk);
  EXPECT_EQ(rover.checker->command_registers(0, regs), 0u);  // frame device
}

TEST_F(ArmTest, SeedRegisterRefusesBadDevices) {
  EXPECT_FALSE(h.checker->seed_register(5, 0, 0));
  Harness rover;
  ASSERT_EQ(rover.load(testing::rover::model()).status, LoadStatus::kOk);
  EXPECT_FALSE(rover.checker->seed_register(0, 0, 0));  // frame device
}

}  // namespace
}  // namespace contego::core
