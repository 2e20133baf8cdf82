// The Linux i2c-dev backend: a real /dev/i2c-N adapter, opened once by the
// trusted side (which should be the only process allowed to open it; see the
// README on device node ownership). Transfers go out as I2C_RDWR, quick
// commands as I2C_SMBUS quick.
#ifndef CONTEGO_BUS_LINUX_I2CDEV_H_
#define CONTEGO_BUS_LINUX_I2CDEV_H_

#include <memory>
#include <mutex>
#include <string>

#include "base/result.h"
#include "bus/bus.h"

namespace contego::bus {

class LinuxI2cDev final : public Bus {
 public:
  // Opens `path` (e.g. "/dev/i2c-1") read-write, close-on-exec, and reads its
  // I2C_FUNCS. Fails with a message naming the path and the errno.
  static Result<std::unique_ptr<LinuxI2cDev>> open(const std::string& path);
  ~LinuxI2cDev() override;

  uint64_t funcs() const override { return funcs_; }
  int transfer(std::span<Msg> msgs) override;
  int quick(uint16_t addr, bool read) override;

 private:
  LinuxI2cDev(int fd, uint64_t funcs) : fd_(fd), funcs_(funcs) {}
  std::mutex mu_;
  int fd_;
  uint64_t funcs_;
};

}  // namespace contego::bus

#endif  // CONTEGO_BUS_LINUX_I2CDEV_H_
