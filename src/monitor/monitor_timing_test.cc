// A descriptor's own I2C_RETRIES and I2C_TIMEOUT under the monitor: each
// acting transfer of its call is tried again on a lost arbitration (EAGAIN)
// by i2c-core's rule (contego_i2c_try_again), timed by the monitor's clock,
// and never through the adapter's own values. A call without them is tried
// once, as before.
#include <errno.h>

#include <gtest/gtest.h>

#include "base/clock.h"
#include "bus/virtual_bus.h"
#include "gate/transfer.h"
#include "monitor/monitor.h"
#include "monitor/test_fake_decider.h"

namespace contego::monitor {
namespace {

// An adapter sharing its bus with another master: its next `lose`
// operations lose arbitration; each try takes `per_try_us` of the clock.
// Reads read 0x2A. The Bus interface has no way to set an adapter's
// retries or timeout, so the monitor cannot have changed them.
class ContendedBus final : public bus::Bus {
 public:
  explicit ContendedBus(ManualClock& clock) : clock_(clock) {}
  uint64_t funcs() const override { return bus::VirtualBus::kFuncs; }
  int transfer(std::span<bus::Msg> msgs) override {
    if (int err = attempt(); err != 0) return err;
    for (bus::Msg& m : msgs) {
      if (m.flags & bus::kMsgRead) std::fill_n(m.buf, m.len, 0x2A);
    }
    return 0;
  }
  int quick(uint16_t, bool) override { return attempt(); }

  uint32_t lose = 0;
  uint64_t per_try_us = 0;
  uint32_t tries = 0;

 private:
  int attempt() {
    ++tries;
    clock_.set_us(clock_.now_us() + per_try_us);
    if (lose == 0) return 0;
    --lose;
    return EAGAIN;
  }
  ManualClock& clock_;
};

// Allows every transaction as sent; one actuator at 0x40.
class AllowAll final : public testing::FakeDecider {
 public:
  AllowAll() { add_device(core::kRoleActuator, 0x40); }
  void check(const core::Transaction& tx, core::Verdict* v) override {
    *v = core::Verdict{};
    v->decision = core::Decision::kAllow;
    v->bus = tx.bus;
    v->addr = tx.addr;
    if (tx.kind == core::TxKind::kWrite) emit(v, {tx.bytes, tx.bytes + tx.len});
  }
  bool safe_state(uint16_t, core::Verdict*) override { return false; }
  uint32_t task_period_us(uint16_t) const override { return period_us; }
  uint32_t period_us = 0;
};

gate::Transfer write(gate::Timing timing) {
  gate::Transfer t;
  t.bus = 1;
  t.messages.push_back({0x40, 0, 2, {0x06, 0x01}});
  t.timing = timing;
  return t;
}

class MonitorTiming : public ::testing::Test {
 protected:
  void SetUp() override { mon.add_bus(1, &bus); }
  // Sends `t` with the bus losing `lost` arbitrations first.
  gate::TransferReply send(const gate::Transfer& t, uint32_t lost) {
    bus.lose = lost;
    bus.tries = 0;
    return mon.transfer(0, t);
  }

  AllowAll decider;
  AuditLog audit;
  ManualClock clock{1'000'000};
  ContendedBus bus{clock};
  Monitor mon{decider, audit, clock};
};

TEST_F(MonitorTiming, ACallSucceedsThroughAsManyLostArbitrationsAsItsRetries) {
  for (uint32_t retries = 0; retries <= 3; ++retries) {
    for (uint32_t lost = 0; lost <= 4; ++lost) {
      const gate::TransferReply reply = send(write({true, retries, 100}), lost);
      EXPECT_EQ(reply.err, lost <= retries ? 0 : EAGAIN) << lost << " lost, retries " << retries;
      EXPECT_EQ(bus.tries, std::min(lost, retries) + 1) << lost << " lost, retries " << retries;
    }
  }
}

TEST_F(MonitorTiming, ADescriptorWithoutItsOwnValuesIsTriedOnce) {
  EXPECT_EQ(send(write({}), 1).err, EAGAIN);
  EXPECT_EQ(bus.tries, 1u);
  EXPECT_EQ(send(write({}), 0).err, 0);
  EXPECT_EQ(bus.tries, 1u);
}

TEST_F(MonitorTiming, TheTimeoutStopsTheRetries) {
  // I2C_TIMEOUT 7 (70 ms), 30 ms a try: the third try ends 90 ms after the
  // first began, past the timeout, so no fourth despite 10 retries.
  bus.per_try_us = 30'000;
  EXPECT_EQ(send(write({true, 10, 7}), 10).err, EAGAIN);
  EXPECT_EQ(bus.tries, 3u);
  // Within it, the same losses are ridden out.
  EXPECT_EQ(send(write({true, 10, 100}), 10).err, 0);
  EXPECT_EQ(bus.tries, 11u);
}

// A task's call is not retried past one period of the task: the monitor's
// lock, held meanwhile, holds every other task's checks.
TEST_F(MonitorTiming, NoCallIsRetriedPastOnePeriodOfItsTask) {
  decider.period_us = 100'000;
  bus.per_try_us = 30'000;
  // I2C_TIMEOUT 214748364 (i2c-dev's most: about 248 days), retries INT_MAX: four tries
  // (90 ms after the first began, the fourth is within the period; a fifth
  // would start 120 ms after it).
  EXPECT_EQ(send(write({true, 2'147'483'647u, 214'748'364u}), 1'000'000).err, EAGAIN);
  EXPECT_EQ(bus.tries, 4u);
  // A timeout shorter than the period is the descriptor's, as before.
  EXPECT_EQ(send(write({true, 10, 7}), 10).err, EAGAIN);
  EXPECT_EQ(bus.tries, 3u);
}

TEST_F(MonitorTiming, EveryActingTransferOfTheCallIsTriedAgain) {
  const gate::Timing two{true, 2, 100};
  gate::Transfer read;  // a register read: pointer and read in one transfer
  read.bus = 1;
  read.messages = {{0x40, 0, 1, {0x06}}, {0x40, gate::kMsgRead, 2, {}}};
  read.timing = two;
  gate::TransferReply reply = send(read, 2);
  EXPECT_EQ(reply.err, 0);
  EXPECT_EQ(bus.tries, 3u);
  ASSERT_EQ(reply.reads.size(), 1u);
  EXPECT_EQ(reply.reads[0], std::vector<uint8_t>({0x2A, 0x2A}));

  gate::Transfer quick;
  quick.bus = 1;
  quick.quick = true;
  quick.quick_addr = 0x40;
  quick.timing = two;
  EXPECT_EQ(send(quick, 2).err, 0);
  EXPECT_EQ(bus.tries, 3u);

  gate::Transfer both = write(two);  // two writes acting as sent: one combined transfer
  both.messages.push_back({0x40, 0, 2, {0x07, 0x02}});
  EXPECT_EQ(send(both, 2).err, 0);
  EXPECT_EQ(bus.tries, 3u);
  EXPECT_EQ(send(both, 3).err, EAGAIN);
  EXPECT_EQ(bus.tries, 3u);
}

}  // namespace
}  // namespace contego::monitor
