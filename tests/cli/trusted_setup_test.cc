// `contego monitor` / `contego run` start fails closed: setup() against
// virtual buses that miss a device, NAK a sensor's sample, refuse a safe
// state, or serve the wrong bus numbers.
#include "cli/trusted_setup.h"

#include <errno.h>
#include <stdlib.h>
#include <unistd.h>

#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <string>

#include "base/test_temp.h"
#include "cli/policy_load.h"
#include "gate/transfer.h"

namespace contego::monitor {
namespace {

const std::string kRover = std::string(CONTEGO_POLICIES_DIR) + "/rover.policy";

// Forwards to a virtual bus, but fails reads or writes at one address.
class FaultyBus final : public bus::Bus {
 public:
  FaultyBus(bus::Bus& inner, uint16_t addr, bool fail_reads, bool fail_writes, int err)
      : inner_(inner), addr_(addr), fail_reads_(fail_reads), fail_writes_(fail_writes), err_(err) {}
  uint64_t funcs() const override { return inner_.funcs(); }
  int transfer(std::span<bus::Msg> msgs) override {
    for (const bus::Msg& m : msgs) {
      const bool read = (m.flags & gate::kMsgRead) != 0;
      if (m.addr == addr_ && ((read && fail_reads_) || (!read && fail_writes_))) return err_;
    }
    return inner_.transfer(msgs);
  }
  int quick(uint16_t addr, bool read) override { return inner_.quick(addr, read); }

 private:
  bus::Bus& inner_;
  uint16_t addr_;
  bool fail_reads_, fail_writes_;
  int err_;
};

class SetupTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("contego-setup", &dir_));
    options_.policy = kRover;
    options_.audit = dir_ + "/audit.jsonl";
    gopigo_ = std::make_shared<bus::GoPiGo2>(0x08);
    line_ = std::make_shared<bus::LineFollower>(0x06);
  }
  void TearDown() override {
    unlink(options_.audit.c_str());
    rmdir(dir_.c_str());
  }
  std::string audit() const {
    std::ifstream in(options_.audit);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // Puts the rover's motor board and line follower on `vb`.
  void attach_devices(bus::VirtualBus& vb) {
    vb.attach(gopigo_);
    vb.attach(line_);
  }
  // Starts on the rover's devices behind a bus that fails at `addr` (its
  // reads and/or writes, with `err`); returns the refusal ("" if it started).
  std::string refusal_behind_faulty_bus(uint16_t addr, bool fail_reads, bool fail_writes, int err) {
    bus::VirtualBus vb;
    attach_devices(vb);
    FaultyBus faulty(vb, addr, fail_reads, fail_writes, err);
    options_.buses = {{1, &faulty}};
    auto t = setup(options_);
    EXPECT_FALSE(t.ok());
    if (t.ok()) {
      (*t)->monitor->stop_sampling();
      return "";
    }
    return t.error();
  }
  std::string dir_;
  SetupOptions options_;
  std::shared_ptr<bus::GoPiGo2> gopigo_;
  std::shared_ptr<bus::LineFollower> line_;
};

TEST_F(SetupTest, HealthyBusStartsAndDrivesTheSafeState) {
  bus::VirtualBus vb;
  attach_devices(vb);
  options_.buses = {{1, &vb}};
  auto t = setup(options_);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_TRUE((*t)->warnings.empty());
  EXPECT_TRUE((*t)->degraded.empty());
  EXPECT_EQ(gopigo_->motion(), 0x78);  // stop()
  EXPECT_GE(gopigo_->frames(), 1u);
  (*t)->monitor->stop_sampling();
}

// contego run --task NAME: a name the policy does not declare is refused
// before anything reaches a bus (it used to drive the safe state first).
TEST_F(SetupTest, UnknownTaskIsRefusedBeforeAnyBusOperation) {
  bus::VirtualBus vb;
  attach_devices(vb);
  options_.buses = {{1, &vb}};
  options_.task = "nosuch";
  auto t = setup(options_);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("declares no task 'nosuch'"), std::string::npos) << t.error();
  EXPECT_EQ(vb.operations(), 0u);
  EXPECT_EQ(gopigo_->frames(), 0u);
}

TEST_F(SetupTest, MissingDeviceRefusesAfterTheProbesOnly) {
  bus::VirtualBus vb;
  vb.attach(line_);  // no GoPiGo2 at 0x08
  options_.buses = {{1, &vb}};
  auto t = setup(options_);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("refusing to start (devices missing):"), std::string::npos) << t.error();
  EXPECT_NE(t.error().find("device gopigo at i2c-1 0x08 does not answer: an SMBus quick write on "
                           "a test bus failed with ENXIO (No such device or address)"),
            std::string::npos)
      << t.error();
  EXPECT_NE(t.error().find("--allow-degraded"), std::string::npos);
  EXPECT_EQ(vb.operations(), 2u);  // one probe per device, nothing else
  EXPECT_EQ(line_->requests(), 0u);
  EXPECT_NE(audit().find("\"kind\":\"start-refused\""), std::string::npos);
}

TEST_F(SetupTest, AllowDegradedStartsAndAuditsIt) {
  bus::VirtualBus vb;
  vb.attach(line_);
  options_.buses = {{1, &vb}};
  options_.allow_degraded = true;
  auto t = setup(options_);
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_FALSE((*t)->degraded.empty());
  EXPECT_NE((*t)->degraded[0].find("device gopigo at i2c-1 0x08 does not answer"),
            std::string::npos);
  EXPECT_NE(audit().find("\"kind\":\"degraded-start\""), std::string::npos);
  (*t)->monitor->stop_sampling();
}

TEST_F(SetupTest, UnreadableSensorRefusesBeforeAnySafeState) {
  const std::string error =
      refusal_behind_faulty_bus(0x06, /*fail_reads=*/true, /*fail_writes=*/false, EIO);
  EXPECT_NE(error.find("refusing to start (sensors unreadable):"), std::string::npos);
  EXPECT_NE(error.find("sensor line at i2c-1 0x06 cannot be read: EIO (Input/output error)"),
            std::string::npos)
      << error;
  EXPECT_EQ(gopigo_->frames(), 0u);  // no safe state was sent
}

TEST_F(SetupTest, SafeStateTheBusRefusesRefusesToStart) {
  const std::string error =
      refusal_behind_faulty_bus(0x08, /*fail_reads=*/false, /*fail_writes=*/true, EREMOTEIO);
  EXPECT_NE(error.find("refusing to start (safe state not applied):"), std::string::npos);
  EXPECT_NE(error.find("safe state of device gopigo at i2c-1 0x08 cannot be applied: "
                       "EREMOTEIO (Remote I/O error)"),
            std::string::npos)
      << error;
  EXPECT_NE(audit().find("\"kind\":\"fault\""), std::string::npos);
}

TEST_F(SetupTest, PolicyBusWithoutAdapterRefusesAndAnUnusedBusWarns) {
  bus::VirtualBus vb;
  attach_devices(vb);
  options_.buses = {{2, &vb}};
  auto t = setup(options_);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("device gopigo at i2c-1 0x08: no adapter for bus 1 (give --bus "
                           "1=/dev/i2c-1 or --virtual-bus 1)"),
            std::string::npos)
      << t.error();
  EXPECT_NE(t.error().find("device line at i2c-1 0x06: no adapter for bus 1"), std::string::npos);
  EXPECT_EQ(vb.operations(), 0u);
  EXPECT_NE(audit().find("bus 2 (a test bus): no device of the policy is on it"),
            std::string::npos);
}

TEST_F(SetupTest, AnUnusedBusBesideTheRightOneOnlyWarns) {
  bus::VirtualBus vb, spare;
  attach_devices(vb);
  options_.buses = {{1, &vb}, {3, &spare}};
  auto t = setup(options_);
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_EQ((*t)->warnings.size(), 1u);
  EXPECT_EQ((*t)->warnings[0],
            "bus 3 (a test bus): no device of the policy is on it; nothing will be sent to it");
  EXPECT_EQ(spare.operations(), 0u);
  (*t)->monitor->stop_sampling();
}

}  // namespace
}  // namespace contego::monitor

namespace contego::monitor {
namespace {

// A PCA9685 configured before contego started (auto-increment on, as the
// vendor library leaves it): the shadow is read back at start (audited), and
// whole-channel auto-increment writes are decided as the device takes them.
TEST(SetupShadow, RegisterMapShadowIsReadBackFromTheDevice) {
  std::string dir;
  ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("contego-setup", &dir));
  SetupOptions o;
  o.policy = std::string(CONTEGO_POLICIES_DIR) + "/boat.policy";
  o.audit = dir + "/audit.jsonl";
  bus::VirtualBus vb;
  auto pca = std::make_shared<bus::Pca9685>(0x40);
  vb.attach(pca);
  const uint8_t mode1[] = {0x00, 0x21};  // AI | ALLCALL, awake
  pca->write(0x40, mode1);
  o.buses = {{1, &vb}};
  auto t = setup(o);
  ASSERT_TRUE(t.ok()) << t.error();
  gate::Transfer tr;
  tr.bus = 1;
  gate::Message m;
  m.addr = 0x40;
  m.data = {0x06, 0x00, 0x00, 0x40, 0x01};  // LED0: on 0, off 320
  m.len = static_cast<uint16_t>(m.data.size());
  tr.messages = {m};
  const uint16_t pilot = (*t)->tasks.at("pilot");
  EXPECT_EQ((*t)->monitor->transfer(pilot, tr).err, 0);
  EXPECT_EQ(pca->led_off(0), 320);
  // Full off through the same auto-increment write: the neutral pulse instead.
  tr.messages[0].data = {0x06, 0x00, 0x00, 0x00, 0x10};
  usleep(25000);  // the next 20 ms period: one pulse per thruster per job
  EXPECT_EQ((*t)->monitor->transfer(pilot, tr).err, 0);
  EXPECT_EQ(pca->led_off(0), 307);
  std::ifstream in(o.audit);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_NE(s.str().find("shadow read back from the device (76 registers)"), std::string::npos);
  EXPECT_NE(s.str().find("\"command_name\":\"led\""), std::string::npos);
  (*t)->monitor->stop_sampling();
  t->reset();
  unlink(o.audit.c_str());
  rmdir(dir.c_str());
}

}  // namespace
}  // namespace contego::monitor
