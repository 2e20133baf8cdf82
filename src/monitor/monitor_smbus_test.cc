// The monitor on an SMBus-only adapter (the virtual bus with i2c-stub's
// I2C_FUNCS): what the adapter can express goes out, what it cannot is
// refused whole before the core decides (no decision, no rate window, no
// byte on the bus), substitutes and safe states that cannot be expressed act
// nothing and say why, and the sampler reads registers in one transaction.
#include <errno.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>

#include "base/test_temp.h"
#include "bus/virtual_bus.h"
#include "gate/transfer.h"
#include "monitor/monitor.h"
#include "monitor/test_fake_decider.h"

namespace contego::monitor {
namespace {

// A register file: a write [reg, data...] stores at reg, reg+1, ...; a
// read returns registers from the pointer on.
class Registers final : public bus::DeviceModel {
 public:
  explicit Registers(uint16_t addr) : addr_(addr) {
    for (int i = 0; i < 256; ++i) regs[i] = static_cast<uint8_t>(i ^ 0xA5);
  }
  bool answers(uint16_t addr) const override { return addr == addr_; }
  void write(uint16_t, std::span<const uint8_t> bytes) override {
    ++writes;
    if (bytes.empty()) return;
    pointer_ = bytes[0];
    for (size_t i = 1; i < bytes.size(); ++i) regs[pointer_++] = bytes[i];
  }
  void read(uint16_t, std::span<uint8_t> out) override {
    for (auto& b : out) b = regs[pointer_++];
  }
  uint8_t regs[256];
  int writes = 0;

 private:
  uint16_t addr_;
  uint8_t pointer_ = 0;
};

// Allows everything, emitting the bytes as sent; writes to 0x41 are replaced
// by a 40-byte frame (a substitute no SMBus transaction carries; or, with
// long_allowed, allowed writes of it).
class CountingDecider final : public testing::FakeDecider {
 public:
  CountingDecider() {
    add_device(core::kRoleActuator, 0x40);
    core::DeviceRecord& sensor = add_device(core::kRoleSensor, 0x48);
    sensor.sample_request_len = 1;
    sensor.sample_request[0] = 0x10;
    sensor.sample_len = 4;
  }
  void check(const core::Transaction& tx, core::Verdict* v) override {
    ++checks;
    *v = core::Verdict{};
    v->bus = tx.bus;
    v->addr = tx.addr;
    v->decision = core::Decision::kAllow;
    if (tx.kind == core::TxKind::kWrite) {
      if (tx.addr == 0x41) {
        v->decision = long_allowed ? core::Decision::kAllow : core::Decision::kFailsafe;
        std::vector<uint8_t> frame(40, 0x11);
        emit(v, frame);
      } else if (split_registers && tx.len > 2) {  // a register map's check, register by register
        for (uint32_t i = 1; i < tx.len; ++i) {
          emit(v, {static_cast<uint8_t>(tx.bytes[0] + i - 1), tx.bytes[i]});
        }
      } else {
        emit(v, std::vector<uint8_t>(tx.bytes, tx.bytes + tx.len));
      }
    }
  }
  bool safe_state(uint16_t device, core::Verdict* v) override {
    if (device != 0) return false;
    *v = core::Verdict{};
    v->decision = core::Decision::kFailsafe;
    v->bus = safe_bus;
    v->addr = 0x40;
    emit(v, safe);
    return true;
  }
  uint32_t task_period_us(uint16_t) const override { return 20000; }

  int checks = 0;
  bool split_registers = false;
  bool long_allowed = false;  // the 40 bytes at 0x41 are the core's writes, not a substitute
  std::vector<uint8_t> safe{0x06, 0x00};
  uint8_t safe_bus = 1;
};

gate::Message wmsg(uint16_t addr, std::vector<uint8_t> bytes) {
  gate::Message m;
  m.addr = addr;
  m.len = static_cast<uint16_t>(bytes.size());
  m.data = std::move(bytes);
  return m;
}

gate::Message rmsg(uint16_t addr, uint16_t len, uint16_t flags = 0) {
  gate::Message m;
  m.addr = addr;
  m.flags = static_cast<uint16_t>(gate::kMsgRead | flags);
  m.len = len;
  return m;
}

class MonitorSmbus : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_file("contego-audit-smbus", &path));
    ASSERT_TRUE(audit.open(path).ok());
    bus.set_funcs(bus::kI2cStubFuncs);
    bus.attach(dev);
    bus.attach(other);
    bus.attach(sensor);
    mon.add_bus(1, &bus);
  }
  void TearDown() override { unlink(path.c_str()); }

  gate::TransferReply send(std::vector<gate::Message> msgs) {
    gate::Transfer t;
    t.bus = 1;
    t.messages = std::move(msgs);
    return mon.transfer(0, t);
  }
  std::string audit_text() {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  std::string path;
  AuditLog audit;
  CountingDecider decider;
  bus::VirtualBus bus;
  std::shared_ptr<Registers> dev = std::make_shared<Registers>(0x40);
  std::shared_ptr<Registers> other = std::make_shared<Registers>(0x41);
  std::shared_ptr<Registers> sensor = std::make_shared<Registers>(0x48);
  Monitor mon{decider, audit};
};

TEST_F(MonitorSmbus, TheEmulationSeesTheAdaptersFuncs) {
  EXPECT_EQ(mon.funcs(1), bus::kI2cStubFuncs);
  EXPECT_EQ(mon.funcs(2), 0u);
}

TEST_F(MonitorSmbus, ExpressibleTransfersGoOut) {
  EXPECT_EQ(send({wmsg(0x40, {0x06, 0x21})}).err, 0);  // write byte data
  EXPECT_EQ(dev->regs[0x06], 0x21);
  EXPECT_EQ(send({wmsg(0x40, {0x01, 40, 0, 0, 0})}).err, 0);  // I2C block write
  EXPECT_EQ(dev->regs[0x01], 40);
  auto r = send({wmsg(0x40, {0x01}), rmsg(0x40, 4)});  // I2C block read
  ASSERT_EQ(r.err, 0);
  ASSERT_EQ(r.reads.size(), 1u);
  EXPECT_EQ(r.reads[0], (std::vector<uint8_t>{40, 0, 0, 0}));
  EXPECT_EQ(decider.checks, 3);
}

TEST_F(MonitorSmbus, InexpressibleTransferIsRefusedBeforeTheCoreDecides) {
  const uint64_t ops = bus.operations();
  // 40 bytes: more than any SMBus write carries.
  auto r = send({wmsg(0x40, std::vector<uint8_t>(40, 0x33))});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  // A register read, then a write no SMBus transaction carries: the read is
  // expressible, but nothing of the call acts.
  r = send({wmsg(0x40, {0x00}), rmsg(0x40, 1), wmsg(0x40, std::vector<uint8_t>(36, 0x44))});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  EXPECT_TRUE(r.reads.empty());
  // A count-prefixed block read: i2c-stub has no SMBus block read.
  r = send({wmsg(0x40, {0x00}), rmsg(0x40, 33, gate::kMsgRecvLen)});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  // A read of 4 bytes without a register byte.
  r = send({rmsg(0x40, 4)});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  EXPECT_EQ(decider.checks, 0);  // the core never saw them
  EXPECT_EQ(mon.decisions(), 0u);
  EXPECT_EQ(bus.operations(), ops);
  EXPECT_EQ(dev->writes, 0);
  const std::string text = audit_text();
  EXPECT_NE(text.find("inexpressible"), std::string::npos) << text;
  EXPECT_NE(text.find("write 40 at 0x40"), std::string::npos) << text;
  EXPECT_NE(text.find("SMBus block read"), std::string::npos) << text;
}

TEST_F(MonitorSmbus, AProcessCallGoesOutAsOneTransfer) {
  // The write and the read answering it were one combined transfer of the
  // program: they go out as one (an SMBus process call here, a repeated
  // start on plain I2C), never as a write, a stop and a lone read (which
  // this adapter could not even express).
  for (const uint64_t funcs : {bus::kI2cStubFuncs | bus::kFuncSmbusProcCall, bus::kFuncI2c}) {
    bus.set_funcs(funcs);
    const uint64_t ops = bus.operations();
    const auto r = send({wmsg(0x40, {0x10, 0x34, 0x12}), rmsg(0x40, 2)});
    ASSERT_EQ(r.err, 0) << funcs;
    EXPECT_EQ(bus.operations(), ops + 1) << funcs;
    EXPECT_EQ(dev->regs[0x10], 0x34);
    ASSERT_EQ(r.reads.size(), 1u);
    EXPECT_EQ(r.reads[0], (std::vector<uint8_t>{dev->regs[0x12], dev->regs[0x13]}));
  }
  // Without the process call on an SMBus-only adapter it has no form:
  // refused whole before the core decides.
  bus.set_funcs(bus::kI2cStubFuncs);
  const int checks = decider.checks;
  EXPECT_EQ(send({wmsg(0x40, {0x10, 0x34, 0x12}), rmsg(0x40, 2)}).err, EOPNOTSUPP);
  EXPECT_EQ(decider.checks, checks);
}

TEST_F(MonitorSmbus, ACallActingAsSentGoesOutAsTheProgramsOneTransfer) {
  // A register read and a write in one call, both allowed as they are: on
  // plain I2C the call goes out whole, no stop between its messages; on an
  // SMBus-only adapter, which has no form for it whole, each transaction in
  // its own.
  for (const uint64_t funcs : {bus::kFuncI2c, bus::kI2cStubFuncs}) {
    bus.set_funcs(funcs);
    dev->regs[0x03] = 0x5A;
    const uint64_t ops = bus.operations();
    const auto r = send({wmsg(0x40, {0x03}), rmsg(0x40, 1), wmsg(0x40, {0x04, 0x66})});
    ASSERT_EQ(r.err, 0) << funcs;
    EXPECT_EQ(bus.operations(), ops + (funcs == bus::kFuncI2c ? 1 : 2)) << funcs;
    ASSERT_EQ(r.reads.size(), 1u);
    EXPECT_EQ(r.reads[0], std::vector<uint8_t>{0x5A});
    EXPECT_EQ(dev->regs[0x04], 0x66);
    dev->regs[0x04] = 0;
  }
}

TEST_F(MonitorSmbus, ABlockWriteCheckedRegisterByRegisterGoesOutAsSent) {
  // The core emits one write per register; put back together they are the
  // program's auto-increment write, which goes out as its one message.
  decider.split_registers = true;
  for (const uint64_t funcs : {bus::kFuncI2c, bus::kI2cStubFuncs}) {
    bus.set_funcs(funcs);
    const uint64_t ops = bus.operations();
    ASSERT_EQ(send({wmsg(0x40, {0x1A, 0x00, 0x00, 0x41, 0x02})}).err, 0) << funcs;
    EXPECT_EQ(bus.operations(), ops + 1) << funcs;
    EXPECT_EQ(dev->regs[0x1C], 0x41);
    EXPECT_EQ(dev->regs[0x1D], 0x02);
  }
}

TEST_F(MonitorSmbus, QuickWithoutTheQuickBitIsRefusedBeforeTheCoreDecides) {
  gate::Transfer t;
  t.bus = 1;
  t.quick = true;
  t.quick_addr = 0x40;
  EXPECT_EQ(mon.transfer(0, t).err, 0);
  EXPECT_EQ(decider.checks, 1);
  bus.set_funcs(bus::kI2cStubFuncs & ~bus::kFuncSmbusQuick);
  EXPECT_EQ(mon.transfer(0, t).err, EOPNOTSUPP);
  EXPECT_EQ(decider.checks, 1);
}

TEST_F(MonitorSmbus, SubstituteThatCannotBeExpressedActsNothing) {
  const uint64_t ops = bus.operations();
  // The write is replaced by a 40-byte frame: it does not reach the bus.
  auto r = send({wmsg(0x41, {0x06, 0x22})});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  EXPECT_EQ(decider.checks, 1);
  EXPECT_EQ(bus.operations(), ops);
  EXPECT_EQ(other->writes, 0);
  EXPECT_NE(audit_text().find("write 40 at 0x41"), std::string::npos) << audit_text();
}

TEST_F(MonitorSmbus, AnEarlierPartDoesNotActWhenALaterPartsWritesHaveNoForm) {
  // Both writes allowed; the core writes 40 bytes for the second, which no
  // SMBus transaction carries: refused before the first acts.
  decider.long_allowed = true;
  dev->regs[0x06] = 0x00;
  const uint64_t ops = bus.operations();
  auto r = send({wmsg(0x40, {0x06, 0x21}), wmsg(0x41, {0x06, 0x22})});
  EXPECT_EQ(r.err, EOPNOTSUPP);
  EXPECT_EQ(decider.checks, 2);
  EXPECT_EQ(bus.operations(), ops);
  EXPECT_EQ(dev->regs[0x06], 0x00);
  EXPECT_EQ(other->writes, 0);
  const std::string text = audit_text();
  EXPECT_NE(text.find("\"inexpressible\""), std::string::npos) << text;
  EXPECT_NE(text.find("task 0: bus 1: write 40 at 0x41"), std::string::npos) << text;
  // On plain I2C it goes.
  bus.set_funcs(bus::kFuncI2c);
  EXPECT_EQ(send({wmsg(0x40, {0x06, 0x21}), wmsg(0x41, {0x06, 0x22})}).err, 0);
  EXPECT_EQ(dev->regs[0x06], 0x21);
}

TEST_F(MonitorSmbus, AWriteCheckedRegisterByRegisterGoesWholeWhereItsRegistersAloneCannot) {
  // An adapter that writes words but no byte data or I2C block: the core's
  // writes of a word write, one per register, have no form there; put back
  // together they are the program's word write, which goes out whole.
  decider.split_registers = true;
  bus.set_funcs(bus::kI2cStubFuncs & ~bus::kFuncSmbusWriteByteData & ~bus::kFuncSmbusWriteI2cBlock);
  const uint64_t ops = bus.operations();
  ASSERT_EQ(send({wmsg(0x40, {0x10, 0x34, 0x12})}).err, 0);
  EXPECT_EQ(bus.operations(), ops + 1);
  EXPECT_EQ(dev->regs[0x10], 0x34);
  EXPECT_EQ(dev->regs[0x11], 0x12);
  EXPECT_EQ(audit_text().find("inexpressible"), std::string::npos) << audit_text();
}

TEST_F(MonitorSmbus, AFailsafeMessageInACombinedTransferDrivesOnlyTheSafeState) {
  // The first write is fine and allowed, the second fails safe: the
  // transfer is replaced by the device's safe state ([06 00]), nothing else.
  auto r = send({wmsg(0x40, {0x06, 0x21}), wmsg(0x41, {0x06, 0x22})});
  EXPECT_EQ(r.err, 0);
  EXPECT_EQ(decider.checks, 2);
  EXPECT_EQ(dev->regs[0x06], 0x00);
  EXPECT_EQ(other->writes, 0);
  EXPECT_NE(audit_text().find("a message of a combined transfer failed safe"), std::string::npos)
      << audit_text();
}

TEST_F(MonitorSmbus, SafeStateThatCannotBeExpressedIsAFaultWithTheReason) {
  mon.drive_safe_state("start");
  EXPECT_EQ(dev->regs[0x06], 0x00);  // [06 00]: write byte data
  decider.safe = std::vector<uint8_t>(40, 0x00);
  mon.drive_safe_state("again");
  const std::string text = audit_text();
  EXPECT_NE(text.find("safe state of device 0 (i2c-1 0x40) failed: errno " +
                      std::to_string(EOPNOTSUPP) + ": write 40 at 0x40"),
            std::string::npos)
      << text;
}

// A reload drives no safe state, so it checks that each has a form: one that
// has none keeps the running policy, its state not carried, nothing written.
TEST_F(MonitorSmbus, AReloadWhoseSafeStateHasNoFormIsRefused) {
  CountingDecider next;
  next.safe = std::vector<uint8_t>(40, 0x00);
  Monitor::Policy policy;
  policy.names.devices = {"arm", "tank"};
  int carried = 0;
  auto carry = [&]() -> Result<std::string> {
    ++carried;
    return std::string("carried");
  };
  const int writes = dev->writes;
  auto refused = mon.reload(next, policy, carry);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error(),
            "the safe state of arm (i2c-1 0x40) has no form on its adapter: write 40 at 0x40: no "
            "SMBus write carries more than a command byte and 32 data bytes (33 bytes, or 34 with "
            "a block count), and the adapter has no plain I2C");
  EXPECT_EQ(carried, 0);
  EXPECT_EQ(dev->writes, writes);
  EXPECT_EQ(send({wmsg(0x40, {0x06, 0x01})}).err, 0);
  EXPECT_EQ(next.checks, 0);  // the running policy still decides
  next.safe = {0x06, 0x00};
  ASSERT_TRUE(mon.reload(next, policy, carry).ok());
  EXPECT_EQ(carried, 1);
  EXPECT_EQ(dev->writes, writes + 1);  // the allowed write only: no safe state driven
  EXPECT_EQ(send({wmsg(0x40, {0x06, 0x01})}).err, 0);
  EXPECT_EQ(next.checks, 1);
}

// A safe state on a bus the monitor lacks (a degraded start) is no new gap
// of the reload: the running policy has the same device there.
TEST_F(MonitorSmbus, AReloadDoesNotRefuseASafeStateOnABusTheMonitorLacks) {
  CountingDecider next;
  next.safe = std::vector<uint8_t>(40, 0x00);
  next.safe_bus = 2;
  auto carry = []() -> Result<std::string> { return std::string("carried"); };
  EXPECT_TRUE(mon.reload(next, Monitor::Policy{}, carry).ok());
}

TEST_F(MonitorSmbus, SamplerReadsARegisterInOneTransaction) {
  mon.sample_all();
  EXPECT_EQ(decider.sample(1), (std::vector<uint8_t>{sensor->regs[0x10], sensor->regs[0x11],
                                                     sensor->regs[0x12], sensor->regs[0x13]}));
  // On a plain I2C adapter the request and the read stay two transfers.
  bus.set_funcs(bus::VirtualBus::kFuncs);
  const uint64_t ops = bus.operations();
  mon.sample_all();
  EXPECT_EQ(bus.operations(), ops + 2);
  EXPECT_EQ(decider.sample(1).size(), 4u);
}

}  // namespace
}  // namespace contego::monitor
