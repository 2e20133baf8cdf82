#include "readings/sensor_readings.h"

#include <gtest/gtest.h>
#include <vector>

namespace contego::readings {
namespace {

constexpr uint16_t kLine = 1;  // device id of the sensor
constexpr uint16_t kFollower = 0, kOther = 1;
const std::vector<uint8_t> kRequest = {1, 3, 0, 0, 0};

class SensorReadingsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    core::DeviceRecord motor{};
    motor.role = core::kRoleActuator;
    motor.bus = 1;
    motor.addr = 0x08;
    core::DeviceRecord line{};
    line.role = core::kRoleSensor;
    line.bus = 1;
    line.addr = 0x06;
    line.sample_request_len = 5;
    std::copy(kRequest.begin(), kRequest.end(), line.sample_request);
    line.sample_len = 10;
    line.max_sample_age_us = 200'000;
    r.reset(2);
    r.describe(0, motor);
    r.describe(kLine, line);
  }
  static std::vector<uint8_t> data(uint8_t v) { return std::vector<uint8_t>(10, v); }
  // A task's read as the vendor library makes it: the request, then the read.
  void task_reads(uint16_t task, uint8_t v, uint64_t at) {
    r.on_write(1, 0x06, kRequest);
    r.on_read(task, 1, 0x06, {}, data(v), at);
  }
  uint8_t judged(uint16_t task, uint64_t now) {
    const Reading* x = r.for_check(task, kLine, now);
    return x == nullptr ? 0 : x->bytes[0];
  }
  SensorReadings r;
};

TEST_F(SensorReadingsTest, TheTasksOwnReadingIsUsedOverANewerSample) {
  task_reads(kFollower, 7, 1'000);
  r.on_sample(kLine, data(9), 100'000);
  EXPECT_EQ(judged(kFollower, 112'000), 7);  // what the controller saw
  EXPECT_EQ(judged(kOther, 112'000), 9);     // another task: the newest
}

TEST_F(SensorReadingsTest, AnOwnReadingOlderThanMaxAgeGivesWayToTheNewest) {
  task_reads(kFollower, 7, 1'000);
  r.on_sample(kLine, data(9), 150'000);
  EXPECT_EQ(judged(kFollower, 201'000), 7);
  EXPECT_EQ(judged(kFollower, 201'001), 9);
}

TEST_F(SensorReadingsTest, AnotherTasksReadingIsTheNewest) {
  r.on_sample(kLine, data(9), 1'000);
  task_reads(kOther, 5, 2'000);
  EXPECT_EQ(judged(kFollower, 3'000), 5);
}

TEST_F(SensorReadingsTest, AReadNotRightAfterTheRequestIsNoReading) {
  r.on_sample(kLine, data(9), 1'000);
  r.on_write(1, 0x06, std::vector<uint8_t>{1, 4, 0, 0, 0});  // another command in between
  r.on_read(kFollower, 1, 0x06, {}, data(7), 2'000);
  EXPECT_EQ(judged(kFollower, 3'000), 9);
  r.on_write(1, 0x06, kRequest);
  r.on_read(kFollower, 1, 0x06, {}, std::vector<uint8_t>(4, 7), 2'500);  // too short
  EXPECT_EQ(judged(kFollower, 3'000), 9);
  r.on_read(kFollower, 1, 0x06, kRequest, data(6), 2'600);  // the request as its pointer
  EXPECT_EQ(judged(kFollower, 3'000), 6);
}

TEST_F(SensorReadingsTest, AFailedSampleDropsEveryReadingAndAnExitedTasksAreForgotten) {
  task_reads(kFollower, 7, 1'000);
  r.on_sample_failed(kLine);
  EXPECT_EQ(r.for_check(kFollower, kLine, 2'000), nullptr);
  task_reads(kFollower, 7, 3'000);
  r.on_sample(kLine, data(9), 4'000);
  r.forget_task(kFollower);
  EXPECT_EQ(judged(kFollower, 5'000), 9);
  EXPECT_EQ(r.for_check(kFollower, 0, 5'000), nullptr);  // not a sensor
}

}  // namespace
}  // namespace contego::readings
