#include "sim/sim_bus.h"

#include <gtest/gtest.h>
#include <memory>

namespace contego::sim {
namespace {

TEST(RegisterFileTest, WritesAndReadsBackWithAutoIncrement) {
  bus::VirtualBus bus;
  auto file = std::make_shared<RegisterFile>(0x48);
  bus.attach(file);
  const uint8_t w[] = {0x02, 5, 6};
  ASSERT_EQ(bus_write(bus, 0x48, w), 0);
  EXPECT_EQ(file->reg(2), 5);
  EXPECT_EQ(file->reg(3), 6);
  const uint8_t ptr[] = {0x02};
  uint8_t out[2] = {};
  ASSERT_EQ(bus_read(bus, 0x48, ptr, out), 0);
  EXPECT_EQ(out[0], 5);
  EXPECT_EQ(out[1], 6);
}

TEST(RegisterFileTest, OtherAddressesAreNotAcknowledged) {
  bus::VirtualBus bus;
  bus.attach(std::make_shared<RegisterFile>(0x48));
  const uint8_t w[] = {0x00, 1};
  EXPECT_NE(bus_write(bus, 0x49, w), 0);
}

void write_regs(bus::Pca9685& chip, std::initializer_list<std::pair<uint8_t, uint8_t>> regs) {
  for (auto [r, v] : regs) {
    const uint8_t b[] = {r, v};
    chip.write(0x40, b);
  }
}

TEST(PwmOutputTest, GripperPulseAt60HzIsAboutTwoAndAHalfMilliseconds) {
  bus::Pca9685 chip;
  write_regs(chip, {{0x00, 0x11}, {0xFE, 0x65}, {0x00, 0x01}});
  write_regs(chip, {{0x1A, 0}, {0x1B, 0}, {0x1C, 0x41}, {0x1D, 0x02}});
  const auto o = pwm_output(chip, 5);
  EXPECT_TRUE(o.active);
  EXPECT_EQ(o.ticks, 577);
  EXPECT_NEAR(o.pulse_us, 577 * 102 / 25.0, 1e-9);
}

TEST(PwmOutputTest, SleepAndFullOffSilenceTheChannel) {
  bus::Pca9685 chip;
  write_regs(chip, {{0x00, 0x01}, {0x1C, 0xA4}, {0x1D, 0x01}});
  EXPECT_TRUE(pwm_output(chip, 5).active);
  EXPECT_FALSE(pwm_output(chip, 4).active);  // power-on full off
  write_regs(chip, {{0x00, 0x11}});
  EXPECT_FALSE(pwm_output(chip, 5).active);
}

TEST(PwmOutputTest, AllLedFullOnReachesTheGripper) {
  bus::Pca9685 chip;
  write_regs(chip, {{0x00, 0x01}, {0x1D, 0x02}, {0xFB, 0x10}});
  EXPECT_TRUE(pwm_output(chip, 5).full_on);
}

}  // namespace
}  // namespace contego::sim
