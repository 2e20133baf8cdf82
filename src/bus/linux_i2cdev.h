// The Linux i2c-dev backend: a real /dev/i2c-N adapter, opened once by the
// trusted side (which should be the only process allowed to open it; see the
// README on device node ownership). Transfers go out as I2C_RDWR when the
// adapter has plain I2C, otherwise as the one I2C_SMBUS transaction that puts
// the same bytes on the wire (bus/smbus_plan.h); a transfer with no such form
// is refused with EOPNOTSUPP before anything reaches the wire. Quick
// commands go out as I2C_SMBUS quick.
#ifndef CONTEGO_BUS_LINUX_I2CDEV_H_
#define CONTEGO_BUS_LINUX_I2CDEV_H_

#include <memory>
#include <string>

#include "base/mutex.h"
#include "base/result.h"
#include "base/unique_fd.h"
#include "bus/bus.h"
#include "bus/smbus_plan.h"

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
  LinuxI2cDev(base::UniqueFd fd, uint64_t funcs) : fd_(std::move(fd)), funcs_(funcs) {}
  int smbus(const SmbusOp& op, std::span<Msg> msgs);
  base::Mutex mu_;
  base::UniqueFd fd_ GUARDED_BY(mu_);  // one transfer at a time on the adapter
  uint64_t funcs_;
};

}  // namespace contego::bus

#endif  // CONTEGO_BUS_LINUX_I2CDEV_H_
