// This machine has no I2C in its kernel, so only the failure paths of the
// real backend can run here: they must name the path and the reason.
#include "bus/linux_i2cdev.h"

#include <gtest/gtest.h>

namespace contego::bus {
namespace {

TEST(LinuxI2cDev, MissingAdapterIsAClearError) {
  auto r = LinuxI2cDev::open("/nonexistent/i2c-7");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("/nonexistent/i2c-7"), std::string::npos);
  EXPECT_NE(r.error().find("No such file"), std::string::npos);
}

TEST(LinuxI2cDev, ANonI2cNodeIsRefused) {
  auto r = LinuxI2cDev::open("/dev/null");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("not an i2c-dev adapter"), std::string::npos);
}

}  // namespace
}  // namespace contego::bus
