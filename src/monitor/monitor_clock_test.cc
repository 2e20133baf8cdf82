// The monitor in virtual time: with a ManualClock it reads time only from
// that clock (the transactions' times and job numbers, its sensor sampling
// and the over-budget hold), which is what lets `contego sim` run it.
#include <gtest/gtest.h>

#include "base/clock.h"
#include "bus/virtual_bus.h"
#include "gate/transfer.h"
#include "monitor/monitor.h"

namespace contego::monitor {
namespace {

// Counts the reads it answers.
class Sensor final : public bus::DeviceModel {
 public:
  bool answers(uint16_t addr) const override { return addr == 0x48; }
  void write(uint16_t, std::span<const uint8_t>) override {}
  void read(uint16_t, std::span<uint8_t> out) override {
    ++reads;
    for (auto& b : out) b = 0x2A;
  }
  int reads = 0;
};

// One actuator (0x40), one sensor (0x48, sampled every 50 ms), one task with
// a 100 ms period and one actuation per job; allows everything and keeps the
// time and job of the last transaction.
class TimedDecider final : public Decider {
 public:
  TimedDecider() {
    devices_[0].role = core::kRoleActuator;
    devices_[0].bus = 1;
    devices_[0].addr = 0x40;
    devices_[1].role = core::kRoleSensor;
    devices_[1].bus = 1;
    devices_[1].addr = 0x48;
    devices_[1].sample_len = 2;
    devices_[1].sample_period_us = 50'000;
  }
  void set_host(const core::Host&) override {}
  void check(const core::Transaction& tx, core::Verdict* v) override {
    now_us = tx.now_us;
    job = tx.job;
    *v = core::Verdict{};
    v->decision = core::Decision::kAllow;
    v->bus = tx.bus;
    v->addr = tx.addr;
    v->emit_count = 1;
    v->emit_len[0] = static_cast<uint16_t>(tx.len);
    for (uint32_t i = 0; i < tx.len; ++i) v->emit_bytes[i] = tx.bytes[i];
  }
  bool safe_state(uint16_t, core::Verdict*) override { return false; }
  uint32_t device_count() const override { return 2; }
  const core::DeviceRecord& device(uint16_t id) const override { return devices_[id]; }
  uint32_t task_period_us(uint16_t task) const override { return task == 0 ? 100'000 : 0; }
  uint32_t task_actuations_per_job(uint16_t task) const override { return task == 0 ? 1 : 0; }

  uint64_t now_us = 0;
  uint32_t job = 0;

 private:
  core::DeviceRecord devices_[2] = {};
};

gate::Transfer write_to_actuator() {
  gate::Transfer t;
  t.bus = 1;
  t.messages.push_back({0x40, 0, 2, {0x01, 0x02}});
  return t;
}

class MonitorClockTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bus.attach(sensor);
    mon.add_bus(1, &bus);
  }

  TimedDecider decider;
  AuditLog audit;
  ManualClock clock{1'000'000};
  bus::VirtualBus bus;  // nothing answers at 0x40: a write fails on the bus after its check
  std::shared_ptr<Sensor> sensor = std::make_shared<Sensor>();
  Monitor mon{decider, audit, clock};
};

TEST_F(MonitorClockTest, TransactionsCarryTheInjectedClocksTimeAndJob) {
  clock.set_us(5'000'000);
  mon.job_boundary(0);  // the task's job grid starts at 5 s
  clock.set_us(5'250'000);
  (void)mon.transfer(0, write_to_actuator());
  EXPECT_EQ(decider.now_us, 5'250'000u);
  EXPECT_EQ(decider.job, 3u);  // [5.2 s, 5.3 s) is job 3 of a 100 ms grid from 5 s
  EXPECT_EQ(mon.job(0), 3u);
}

TEST_F(MonitorClockTest, SensorsAreSampledOnTheirPeriodInVirtualTime) {
  EXPECT_EQ(mon.sample_due(), 1'050'000u);  // sampled now; next in 50 ms
  EXPECT_EQ(sensor->reads, 1);
  clock.set_us(1'049'999);
  EXPECT_EQ(mon.sample_due(), 1'050'000u);  // not yet due
  EXPECT_EQ(sensor->reads, 1);
  clock.set_us(1'050'000);
  EXPECT_EQ(mon.sample_due(), 1'100'000u);
  EXPECT_EQ(sensor->reads, 2);
}

TEST_F(MonitorClockTest, AnOverBudgetTransferWaitsOnTheInjectedClock) {
  clock.set_us(2'000'000);
  mon.set_budget_factor(1);

  mon.job_boundary(0);
  clock.set_us(2'010'000);
  (void)mon.transfer(0, write_to_actuator());  // the job's one actuation
  EXPECT_EQ(mon.holds(), 0u);
  (void)mon.transfer(0, write_to_actuator());  // over budget: held to the next release
  EXPECT_EQ(mon.holds(), 1u);
  EXPECT_EQ(clock.now_us(), 2'100'000u);  // the hold slept on the monitor's clock
  EXPECT_EQ(decider.now_us, 2'100'000u);
  EXPECT_EQ(decider.job, 2u);
}

}  // namespace
}  // namespace contego::monitor
