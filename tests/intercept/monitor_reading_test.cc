// The real monitor with the example rover policy through the real core: a
// command is judged against the line reading its own task made through the
// monitor, not against the monitor's newer sample (the rover moved since), and
// a spoofed command in the same job is still caught.
#include <stdlib.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <memory>
#include <string>

#include "bus/virtual_bus.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "policy/compile.h"
#include "test_support.h"

namespace contego {
namespace {

constexpr uint16_t kFollower = 0;
const std::array<uint16_t, 5> kLineFarRight = {767, 815, 859, 1003, 1004};  // pos 15000: INV2
const std::array<uint16_t, 5> kLineCentre = {767, 815, 1015, 710, 700};     // pos 0: INV3

class MonitorReading : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(
        test_support::open_temp_audit(audit, &audit_path, "/tmp/contego-reading-audit-XXXXXX"));
    policy::CompileOutput out;
    ASSERT_NO_FATAL_FAILURE(test_support::load_policy(
        std::string(CONTEGO_POLICIES_DIR) + "/rover.policy", decider, &out));
    bus.attach(gpg);
    bus.attach(lf);
    mon = std::make_unique<monitor::Monitor>(decider, audit);
    mon->add_bus(1, &bus);
  }
  void TearDown() override { unlink(audit_path.c_str()); }

  gate::TransferReply write(std::vector<uint8_t> bytes, uint16_t addr = 0x08) {
    gate::Transfer t;
    t.bus = 1;
    gate::Message m;
    m.addr = addr;
    m.len = static_cast<uint16_t>(bytes.size());
    m.data = std::move(bytes);
    t.messages.push_back(m);
    return mon->transfer(kFollower, t);
  }
  // The vendor's sensor read: the analog-read request, then ten bytes.
  void read_line() {
    ASSERT_EQ(write({1, 3, 0, 0, 0}, 0x06).err, 0);
    gate::Transfer t;
    t.bus = 1;
    gate::Message m;
    m.addr = 0x06;
    m.flags = gate::kMsgRead;
    m.len = 10;
    t.messages.push_back(m);
    const gate::TransferReply r = mon->transfer(kFollower, t);
    ASSERT_EQ(r.err, 0);
    ASSERT_EQ(r.reads.size(), 1u);
  }

  std::string audit_path;
  monitor::AuditLog audit;
  monitor::CoreDecider decider;
  bus::VirtualBus bus;
  std::shared_ptr<bus::GoPiGo2> gpg = std::make_shared<bus::GoPiGo2>(0x08);
  std::shared_ptr<bus::LineFollower> lf = std::make_shared<bus::LineFollower>(0x06);
  std::unique_ptr<monitor::Monitor> mon;
};

TEST_F(MonitorReading, HonestFramesAreJudgedAgainstTheReadingTheControllerMade) {
  lf->set_values(kLineFarRight);
  read_line();  // the controller sees the line far right: left at 125
  lf->set_values(kLineCentre);
  mon->sample_all();  // the monitor's own, newer sample says: forward at 80
  ASSERT_EQ(write({1, 70, 125, 0, 0}).err, 0);
  ASSERT_EQ(write({1, 71, 125, 0, 0}).err, 0);
  ASSERT_EQ(write({1, 97, 0, 0, 0}).err, 0);
  EXPECT_EQ(gpg->left_speed(), 125);
  EXPECT_EQ(gpg->right_speed(), 125);
  EXPECT_EQ(gpg->motion(), 97);  // left(), as sent
}

TEST_F(MonitorReading, ASpoofedFrameInTheSameJobIsStillCaught) {
  lf->set_values(kLineFarRight);
  read_line();
  const uint32_t job = mon->job(kFollower);
  ASSERT_EQ(write({1, 70, 125, 0, 0}).err, 0);
  ASSERT_EQ(write({1, 71, 0, 0, 0}).err, 0);  // the spoof: right wheel off
  EXPECT_EQ(gpg->right_speed(), 125);         // FAIL-SAFE: the expected speed went out
  EXPECT_EQ(mon->job(kFollower), job);
}

TEST_F(MonitorReading, WithoutAReadingOfItsOwnTheNewestSampleDecides) {
  lf->set_values(kLineCentre);
  mon->sample_all();
  ASSERT_EQ(write({1, 70, 125, 0, 0}).err, 0);  // the line is centred: 80 expected
  EXPECT_EQ(gpg->left_speed(), 80);
}

}  // namespace
}  // namespace contego
