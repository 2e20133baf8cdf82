// Transfers (several transactions as one unit) and the addresses no policy
// models (general call beyond its declared commands, reserved addresses), on
// the PCA9685-like arm.
#include <gtest/gtest.h>

#include "contego/core_c.h"

#include "core/test_fixtures.h"

namespace contego::core {
namespace {

using namespace testing::arm_tests;  // NOLINT(google-build-using-namespace)

class TransferTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(h.load(arm::model()).status, LoadStatus::kOk);
    ASSERT_TRUE(h.checker->seed_register(arm::kArm, 0x00, 0x21));  // auto-increment on
  }
  Verdict send(Bytes bytes, uint16_t addr = kAddr, TxKind kind = TxKind::kWrite) {
    return h.check(arm::kController, addr, std::move(bytes), ++now, 0, kind);
  }
  // Checks `messages` as one transfer and ends it as combine_transfer says.
  TransferVerdict transfer(const std::vector<Bytes>& messages) {
    h.checker->begin_transfer();
    std::vector<Verdict> verdicts;
    for (const Bytes& m : messages) {
      verdicts.push_back(send(m));
      if (verdicts.back().decision == Decision::kReject) break;
    }
    const TransferVerdict t =
        combine_transfer(verdicts.data(), static_cast<uint32_t>(verdicts.size()));
    if (t.action == TransferAction::kPerform || t.action == TransferAction::kSubstitute) {
      h.checker->commit_transfer();
    } else {
      h.checker->abort_transfer(transfer_decision(t.action));
    }
    return t;
  }
  Bytes shadow() const {
    Bytes out(256);
    for (uint32_t r = 0; r < 256; ++r) {
      EXPECT_TRUE(h.checker->shadow(arm::kArm, static_cast<uint8_t>(r), &out[r]));
    }
    return out;
  }
  uint64_t now = 1000;
  Harness h;
};

TEST_F(TransferTest, ARefusedSecondMessageLeavesTheModelByteIdentical) {
  // Some history, a state word at step 1 and a staged byte before the transfer.
  ASSERT_EQ(send({kLed5, 0, 0, 0xA4, 0x01}).decision, Decision::kAllow);  // 420: step 0 -> 1
  h.checker->seed_register(arm::kArm, 0x00, 0x01);                        // AI off for one byte
  ASSERT_EQ(send({kLed5 + 2, 0x77}).reason, Reason::kStaged);
  h.checker->seed_register(arm::kArm, 0x00, 0x21);
  const uint32_t crc = h.checker->model_crc();
  const Bytes before = shadow();

  // 577 (step 1 -> 0, new shadow, new history, LED5's staging consumed), then TEST_MODE.
  const TransferVerdict t =
      transfer({{kLed5, 0, 0, 0x41, 0x02}, {kLed4, 0, 0, 0x77, 0x01}, {0xFF, 0x01}});
  EXPECT_EQ(t.action, TransferAction::kRefuse);
  EXPECT_EQ(t.decider, 2u);
  EXPECT_EQ(h.checker->model_crc(), crc);
  EXPECT_EQ(shadow(), before);
  ASSERT_FALSE(h.audits.empty());
  EXPECT_EQ(h.audits.back().reason, Reason::kTransferDropped);
  EXPECT_EQ(h.audits.back().decision, Decision::kReject);
  // Still at step 1: 577 is what the sequence accepts now, and only once.
  EXPECT_EQ(send({kLed5, 0, 0, 0x41, 0x02}).decision, Decision::kAllow);
  EXPECT_EQ(send({kLed5, 0, 0, 0x41, 0x02}).decision, Decision::kReject);
}

TEST_F(TransferTest, StagingItsChecksDroppedStaysDroppedWhenTheTransferIsRefused) {
  h.checker->seed_register(arm::kArm, 0x00, 0x01);  // AI off: one register per write
  ASSERT_EQ(send({kLed4 + 2, 0x77}).reason, Reason::kStaged);
  h.checker->seed_register(arm::kArm, 0x00, 0x21);
  // LED5 whole: the task left LED4 incomplete (its staged byte is dropped,
  // audited); then TEST_MODE refuses the transfer.
  h.checker->begin_transfer();
  EXPECT_EQ(send({kLed5, 0, 0, 0xA4, 0x01}).decision, Decision::kAllow);
  ASSERT_FALSE(h.audits.empty());
  EXPECT_EQ(h.audits[0].reason, Reason::kStagedIncomplete);
  EXPECT_EQ(h.audits[0].decision, Decision::kIgnore);
  EXPECT_EQ(h.audits[0].index, 4);
  EXPECT_EQ(send({0xFF, 0x01}).decision, Decision::kReject);
  h.checker->abort_transfer(Decision::kReject);
  // The abort did not bring the dropped byte back: LED4's OFF_H alone
  // commits the shadow's OFF_L, not the 0x77 the device never got.
  h.checker->seed_register(arm::kArm, 0x00, 0x01);
  ASSERT_EQ(send({kLed4 + 3, 0x01}).decision, Decision::kAllow);
  EXPECT_EQ(shadow()[kLed4 + 2], 0x00);
}

TEST_F(TransferTest, AnotherTasksStagingDisplacedByAnActingCheckStaysDroppedAsRecorded) {
  image::ImageModel m = arm::model();
  m.access[arm::kOther].actuate_devices = 1u << arm::kArm;
  ASSERT_EQ(h.load(m).status, LoadStatus::kOk);
  h.checker->seed_register(arm::kArm, 0x00, 0x01);  // AI off: one register per write
  ASSERT_EQ(send({kLed4 + 2, 0xA4}).reason, Reason::kStaged);
  // The other task's OFF_L displaces it and acts (staged): the record is
  // made; the transfer is then refused, and the drop stays as recorded.
  h.checker->begin_transfer();
  EXPECT_EQ(h.check(arm::kOther, kAddr, {kLed4 + 2, 0x41}, ++now).reason, Reason::kStaged);
  ASSERT_EQ(h.audits.size(), 2u);
  EXPECT_EQ(h.audits[0].reason, Reason::kStagingConflict);
  EXPECT_EQ(h.audits[0].task, arm::kController);
  EXPECT_EQ(h.audits[0].index, 4);
  EXPECT_EQ(h.check(arm::kOther, kAddr, {0xFF, 0x01}, ++now).decision, Decision::kReject);
  h.checker->abort_transfer(Decision::kReject);
  // Neither task's OFF_L is staged now: OFF_H alone commits the shadow's 0.
  const Verdict v = send({kLed4 + 3, 0x01});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (Writes{{kLed4 + 3, 0x01}}));
  EXPECT_EQ(shadow()[kLed4 + 2], 0x00);
}

TEST_F(TransferTest, AnAllowedTransferCommitsEveryMessage) {
  const uint32_t crc = h.checker->model_crc();
  const TransferVerdict t = transfer({{kLed5, 0, 0, 0xA4, 0x01}, {kLed4, 0, 0, 0x77, 0x01}});
  EXPECT_EQ(t.action, TransferAction::kPerform);
  EXPECT_NE(h.checker->model_crc(), crc);
  const Bytes s = shadow();
  EXPECT_EQ((Bytes{s[kLed5 + 2], s[kLed5 + 3], s[kLed4 + 2], s[kLed4 + 3]}),
            (Bytes{0xA4, 0x01, 0x77, 0x01}));
  // The sequence moved to step 1 with the transfer: 420 again is refused.
  EXPECT_EQ(send({kLed5, 0, 0, 0xA4, 0x01}).decision, Decision::kReject);
}

TEST_F(TransferTest, LaterMessagesSeeWhatEarlierOnesStaged) {
  h.checker->seed_register(arm::kArm, 0x00, 0x01);  // AI off: one register per write
  const TransferVerdict t = transfer({{kLed4 + 2, 0x77}, {kLed4 + 3, 0x01}});
  EXPECT_EQ(t.action, TransferAction::kPerform);
  uint8_t v = 0;
  ASSERT_TRUE(h.checker->shadow(arm::kArm, kLed4 + 2, &v));
  EXPECT_EQ(v, 0x77);
}

TEST_F(TransferTest, AnIgnoredOrFailsafeMessageDropsTheOthers) {
  const uint32_t crc = h.checker->model_crc();
  // Off = 700: out of range, the arm's response is fail-safe (centre).
  TransferVerdict t = transfer({{kLed4, 0, 0, 0x77, 0x01}, {kLed5 - 4, 0, 0, 0xBC, 0x02}});
  EXPECT_EQ(t.action, TransferAction::kSafeState);
  EXPECT_EQ(t.decider, 1u);
  EXPECT_EQ(h.checker->model_crc(), crc);
  EXPECT_EQ(h.audits.back().reason, Reason::kTransferDropped);
  EXPECT_EQ(h.audits.back().decision, Decision::kFailsafe);
  // One message alone keeps its substitute (and its model change).
  t = transfer({{kLed5 - 4, 0, 0, 0xBC, 0x02}});
  EXPECT_EQ(t.action, TransferAction::kSubstitute);
  EXPECT_NE(h.checker->model_crc(), crc);
}

TEST_F(TransferTest, AMessageThatCannotBeUndoneIsRefused) {
  // kMaxTransferHistory "last command" slots: one per committed command.
  std::vector<Bytes> messages;
  for (uint32_t i = 0; i <= kMaxTransferHistory; ++i) messages.push_back({kLed4, 0, 0, 0x77, 0x01});
  const uint32_t crc = h.checker->model_crc();
  const TransferVerdict t = transfer(messages);
  EXPECT_EQ(t.action, TransferAction::kRefuse);
  EXPECT_EQ(t.decider, kMaxTransferHistory);
  EXPECT_EQ(h.checker->model_crc(), crc);
}

TEST_F(TransferTest, TheCFacadeCombinesAndAborts) {
  Verdict v[2]{};
  v[0].decision = Decision::kAllow;
  v[1].decision = Decision::kIgnore;
  uint32_t decider = 9;
  const contego_verdict* cv = reinterpret_cast<const contego_verdict*>(v);
  EXPECT_EQ(contego_combine_transfer(cv, 2, &decider),
            static_cast<uint8_t>(TransferAction::kIgnore));
  EXPECT_EQ(decider, 1u);
  v[1].decision = Decision::kFailsafe;
  EXPECT_EQ(contego_combine_transfer(cv, 2, &decider),
            static_cast<uint8_t>(TransferAction::kSafeState));
  EXPECT_EQ(contego_combine_transfer(cv + 1, 1, &decider),
            static_cast<uint8_t>(TransferAction::kSubstitute));
  v[1].decision = static_cast<Decision>(7);  // unknown: fails closed
  EXPECT_EQ(contego_combine_transfer(cv, 2, &decider),
            static_cast<uint8_t>(TransferAction::kRefuse));
  EXPECT_EQ(contego_combine_transfer(cv, 1, &decider),
            static_cast<uint8_t>(TransferAction::kPerform));
}

// --- addresses ---------------------------------------------------------------------

TEST_F(TransferTest, AGeneralCallIsIgnoredUnlessItIsADeclaredCommand) {
  const uint32_t crc = h.checker->model_crc();
  // LED0 through the general call: on the wire `06 ...`, a PCA9685 software reset.
  for (const Bytes& b : {Bytes{0x06, 0, 0, 0x77, 0x01}, Bytes{0x01, 0x04}, Bytes{0x06, 0x00}}) {
    const Verdict v = send(b, 0x00);
    EXPECT_EQ(v.decision, Decision::kIgnore);
    EXPECT_EQ(v.reason, Reason::kGeneralCall);
    EXPECT_EQ(v.emit_count, 0);
    ASSERT_EQ(h.audits.size(), 1u);
    EXPECT_STREQ(reason_name(h.audits[0].reason), "general-call");
  }
  EXPECT_EQ(send({}, 0x00, TxKind::kRead).reason, Reason::kGeneralCall);
  EXPECT_EQ(send({}, 0x00, TxKind::kQuick).reason, Reason::kGeneralCall);
  EXPECT_EQ(h.checker->model_crc(), crc);
  // No listener on bus 2: ignored as well.
  EXPECT_EQ(h.check(arm::kController, 0x00, {0x06}, ++now, 0, TxKind::kWrite, 2).reason,
            Reason::kGeneralCall);
}

TEST_F(TransferTest, ReservedAddressesWithoutADeclaredDeviceAreRejected) {
  for (const uint16_t addr : std::vector<uint16_t>{0x01, 0x04, 0x07, 0x78, 0x7B, 0x7F}) {
    const Verdict v = send({0x06, 0x00}, addr);
    EXPECT_EQ(v.decision, Decision::kReject) << addr;
    EXPECT_EQ(v.reason, Reason::kReservedAddress) << addr;
    EXPECT_EQ(v.emit_count, 0);
  }
  // A device the policy declares at a reserved address is modelled (the
  // rover's line follower is at 0x06) unless a 10-bit device shares the bus.
  image::ImageModel m = arm::model();
  m.devices[arm::kArm].record.addr = 0x78;
  ASSERT_EQ(h.load(m).status, LoadStatus::kOk);
  EXPECT_EQ(send({0x01, 0x04}, 0x78).decision, Decision::kAllow);
  image::Named<DeviceRecord> ten = m.devices[arm::kArm];
  ten.name = "ten";
  ten.record.addr = 0x040;
  ten.record.ten_bit = 1;
  ten.record.safe_count = 0;
  ten.record.command_count = 0;
  m.devices.push_back(ten);
  const LoadResult r = h.load(m);
  ASSERT_EQ(r.status, LoadStatus::kOk) << load_status_name(r.status) << " " << r.section;
  EXPECT_EQ(send({0x01, 0x04}, 0x78).reason, Reason::kReservedAddress);
  ASSERT_EQ(h.load(arm::model()).status, LoadStatus::kOk);
  // A 10-bit address the policy does not declare is no device.
  Transaction tx{};
  const uint8_t bytes[2] = {0x06, 0x00};
  tx.task = arm::kController;
  tx.bus = 1;
  tx.kind = TxKind::kWrite;
  tx.addr = 0x040;
  tx.ten_bit = 1;
  tx.len = 2;
  tx.bytes = bytes;
  Verdict v{};
  h.checker->check(tx, &v);
  EXPECT_EQ(v.reason, Reason::kUnknownDevice);
  EXPECT_EQ(v.emit_count, 0);
}

}  // namespace
}  // namespace contego::core
