#include "bus/virtual_bus.h"

#include <errno.h>

#include <gtest/gtest.h>
#include <vector>

namespace contego::bus {
namespace {

class VirtualBusTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bus.attach(pca);
    bus.attach(gpg);
    bus.attach(lf);
  }
  int write(uint16_t addr, std::vector<uint8_t> bytes) {
    Msg m{addr, 0, static_cast<uint16_t>(bytes.size()), bytes.data()};
    return bus.transfer({&m, 1});
  }
  std::vector<uint8_t> read(uint16_t addr, uint16_t n, std::vector<uint8_t> pointer = {}) {
    std::vector<uint8_t> out(n);
    std::vector<Msg> msgs;
    if (!pointer.empty()) {
      msgs.push_back({addr, 0, static_cast<uint16_t>(pointer.size()), pointer.data()});
    }
    msgs.push_back({addr, 1, n, out.data()});
    EXPECT_EQ(bus.transfer(msgs), 0);
    return out;
  }

  VirtualBus bus;
  std::shared_ptr<Pca9685> pca = std::make_shared<Pca9685>();
  std::shared_ptr<GoPiGo2> gpg = std::make_shared<GoPiGo2>();
  std::shared_ptr<LineFollower> lf = std::make_shared<LineFollower>();
};

TEST_F(VirtualBusTest, AnswersFuncsLikeAnI2cAndSmbusAdapter) {
  EXPECT_TRUE(bus.funcs() & kFuncI2c);
  EXPECT_TRUE(bus.funcs() & kFuncSmbusQuick);
  EXPECT_EQ(bus.funcs() & 0x00FF0000u, 0x00FF0000u);  // quick, byte, byte data, word, proc call
  EXPECT_EQ(bus.funcs() & kFuncSmbusI2cBlock, kFuncSmbusI2cBlock);
}

TEST_F(VirtualBusTest, AbsentAddressIsNotAcknowledged) {
  EXPECT_EQ(write(0x41, {0x00, 0x01}), ENXIO);
  EXPECT_EQ(bus.quick(0x41, false), ENXIO);
  EXPECT_EQ(bus.quick(0x40, false), 0);
}

// Every Bus applies the shared allow-list (contego/i2c_msg_flags.h) last, so
// a flag no client should have let through never reaches a device model.
TEST_F(VirtualBusTest, RefusesFlagsOutsideTheAllowListBeforeAnyMessageActs) {
  std::vector<uint8_t> led[] = {{0x1A, 0x00}, {}};
  uint8_t got[2] = {};
  std::vector<uint8_t> pointer = {0xFE};
  for (const unsigned flag :
       {CONTEGO_I2C_M_NOSTART, CONTEGO_I2C_M_REV_DIR_ADDR, CONTEGO_I2C_M_IGNORE_NAK,
        CONTEGO_I2C_M_NO_RD_ACK, CONTEGO_I2C_M_STOP}) {
    Msg msgs[3] = {{0x40, 0, 2, led[0].data()},
                   {0x40, 0, 1, pointer.data()},
                   {0x40, static_cast<uint16_t>(kMsgRead | flag), 2, got}};
    EXPECT_EQ(bus.transfer(msgs), EINVAL) << flag;
    msgs[2].flags = kMsgRead;
    msgs[0].flags = static_cast<uint16_t>(flag);
    EXPECT_EQ(bus.transfer(msgs), EINVAL) << flag;
  }
  EXPECT_EQ(bus.operations(), 0u);
  EXPECT_EQ(read(0x40, 1, {0x1A})[0], 0x00);
}

TEST_F(VirtualBusTest, Pca9685PowerOnAndChannelWrites) {
  EXPECT_EQ(read(0x40, 1, {0x00})[0], 0x11);
  EXPECT_EQ(read(0x40, 1, {0xFE})[0], 0x1E);
  // set_pwm(5, 0, 577) as four single-byte register writes
  EXPECT_EQ(write(0x40, {0x1A, 0x00}), 0);
  EXPECT_EQ(write(0x40, {0x1B, 0x00}), 0);
  EXPECT_EQ(write(0x40, {0x1C, 0x41}), 0);
  EXPECT_EQ(write(0x40, {0x1D, 0x02}), 0);
  EXPECT_EQ(pca->led_off(5), 577);
}

TEST_F(VirtualBusTest, Pca9685AutoIncrementOnlyWithMode1Ai) {
  write(0x40, {0x00, 0x01});  // AI off: bytes land in the same register
  write(0x40, {0x1C, 0xA4, 0x01});
  EXPECT_EQ(pca->reg(0x1C), 0x01);
  write(0x40, {0x00, 0x21});  // AI on
  write(0x40, {0x1A, 0x00, 0x00, 0xA4, 0x01});
  EXPECT_EQ(pca->led_off(5), 420);
}

TEST_F(VirtualBusTest, Pca9685PrescaleOnlyWhileAsleep) {
  write(0x40, {0x00, 0x01});  // awake
  write(0x40, {0xFE, 0x03});
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
  write(0x40, {0x00, 0x11});  // asleep
  write(0x40, {0xFE, 0x65});
  EXPECT_EQ(pca->reg(0xFE), 0x65);
}

TEST_F(VirtualBusTest, Pca9685AllCallAndAllLedAndSoftwareReset) {
  EXPECT_EQ(write(0x70, {0xFD, 0x10}), 0);  // all-call enabled at power-on
  for (int ch = 0; ch < 16; ++ch) EXPECT_EQ(pca->led_off(ch), 0x1000);
  write(0x40, {0x00, 0x00});  // ALLCALL off
  EXPECT_EQ(write(0x70, {0xFD, 0x00}), ENXIO);
  write(0x40, {0x08, 0x55});
  EXPECT_EQ(write(0x00, {0x06}), 0);  // SWRST
  EXPECT_EQ(pca->reg(0x08), 0x00);
  EXPECT_EQ(pca->reg(0x00), 0x11);
}

TEST_F(VirtualBusTest, GoPiGoActsOnTheLastFourBytes) {
  EXPECT_EQ(write(0x08, {0x01, 0x46, 150, 0, 0}), 0);  // set_left_speed(150), 5-byte framing
  EXPECT_EQ(write(0x08, {0x47, 80, 0, 0}), 0);         // set_right_speed(80), 4-byte framing
  EXPECT_EQ(gpg->left_speed(), 150);
  EXPECT_EQ(gpg->right_speed(), 80);
  write(0x08, {0x01, 0x77, 0, 0, 0});
  EXPECT_EQ(gpg->motion(), 0x77);
  write(0x08, {0x01, 0x72, 0, 0, 0});  // read_motor_speed, then two 1-byte reads
  EXPECT_EQ(read(0x08, 1)[0], 80);
  EXPECT_EQ(read(0x08, 1)[0], 150);
  EXPECT_EQ(read(0x08, 1)[0], 0);     // status byte afterwards
  EXPECT_EQ(write(0x08, {0x78}), 0);  // too short: ignored
  EXPECT_EQ(gpg->motion(), 0x77);
}

TEST_F(VirtualBusTest, LineFollowerServesFiveBigEndianValues) {
  lf->set_values({700, 1012, 0, 1023, 5});
  EXPECT_EQ(write(0x06, {0x01, 0x03, 0, 0, 0}), 0);
  auto v = read(0x06, 10);
  EXPECT_EQ(v, (std::vector<uint8_t>{0x02, 0xBC, 0x03, 0xF4, 0, 0, 0x03, 0xFF, 0, 5}));
  EXPECT_EQ(lf->requests(), 1u);
}

TEST_F(VirtualBusTest, RecvLenReadsTheCountThenTheData) {
  write(0x40, {0x00, 0x21});           // AI on
  write(0x40, {0x06, 0x03, 9, 8, 7});  // LED0_ON_L = 3 (the count), then data
  std::vector<uint8_t> ptr{0x06};
  std::vector<uint8_t> out(33);
  Msg msgs[2] = {{0x40, 0, 1, ptr.data()}, {0x40, 0x0401, 33, out.data()}};
  ASSERT_EQ(bus.transfer(msgs), 0);
  EXPECT_EQ(msgs[1].len, 4);
  EXPECT_EQ(out[0], 3);
  EXPECT_EQ(out[3], 7);
}

}  // namespace
}  // namespace contego::bus
