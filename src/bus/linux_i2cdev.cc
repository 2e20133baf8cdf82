#include "bus/linux_i2cdev.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <vector>

#include "bus/smbus_plan.h"

namespace contego::bus {

Result<std::unique_ptr<LinuxI2cDev>> LinuxI2cDev::open(const std::string& path) {
  base::UniqueFd fd(::open(path.c_str(), O_RDWR | O_CLOEXEC));
  if (!fd.valid()) return make_error("cannot open " + path + ": " + std::strerror(errno));
  unsigned long funcs = 0;
  if (::ioctl(fd.get(), I2C_FUNCS, &funcs) != 0) {
    return make_error(path + " is not an i2c-dev adapter (I2C_FUNCS: " + std::strerror(errno) +
                      ")");
  }
  return std::unique_ptr<LinuxI2cDev>(new LinuxI2cDev(std::move(fd), funcs));
}

LinuxI2cDev::~LinuxI2cDev() = default;

int LinuxI2cDev::transfer(std::span<Msg> msgs) {
  if (msgs.empty() || msgs.size() > I2C_RDWR_IOCTL_MAX_MSGS) return EINVAL;
  if (carries_refused_flags(msgs)) return EINVAL;
  const Plan plan = plan_transfer(msgs, funcs_);
  if (plan.form == Plan::Form::kRefused) return EOPNOTSUPP;
  if (plan.form == Plan::Form::kSmbus) return smbus(plan.op, msgs);
  std::vector<i2c_msg> raw(msgs.size());
  for (size_t i = 0; i < msgs.size(); ++i) {
    raw[i].addr = msgs[i].addr;
    raw[i].flags = msgs[i].flags;
    raw[i].len = msgs[i].len;
    raw[i].buf = msgs[i].buf;
    if (msgs[i].flags & kMsgRecvLen) {
      // The kernel wants the extra-byte count preset in buf[0] (1 for SMBus).
      if (msgs[i].len < 1 + I2C_SMBUS_BLOCK_MAX) return EINVAL;
      msgs[i].buf[0] = 1;
    }
  }
  i2c_rdwr_ioctl_data arg{raw.data(), static_cast<uint32_t>(raw.size())};
  base::MutexLock lock(mu_);
  if (::ioctl(fd_.get(), I2C_RDWR, &arg) < 0) return errno;
  for (size_t i = 0; i < msgs.size(); ++i) msgs[i].len = raw[i].len;
  return 0;
}

int LinuxI2cDev::smbus(const SmbusOp& op, std::span<Msg> msgs) {
  i2c_smbus_data data{};
  switch (op.size) {
    case SmbusSize::kByte:
    case SmbusSize::kByteData:
      data.byte = op.data[0];
      break;
    case SmbusSize::kWordData:
    case SmbusSize::kProcCall:
      data.word = static_cast<uint16_t>(op.data[0] | (op.data[1] << 8));
      break;
    default:
      std::memcpy(data.block, op.data.data(), sizeof data.block);
      break;
  }
  i2c_smbus_ioctl_data arg{};
  arg.read_write = op.read ? I2C_SMBUS_READ : I2C_SMBUS_WRITE;
  arg.command = op.command;
  arg.size = static_cast<uint32_t>(op.size);
  arg.data = &data;
  {
    base::MutexLock lock(mu_);
    // The monitor owns the adapter: FORCE, so a kernel driver bound to the
    // address does not make the transfer fail differently from I2C_RDWR.
    if (::ioctl(fd_.get(), I2C_SLAVE_FORCE, static_cast<unsigned long>(op.addr)) < 0) return errno;
    if (::ioctl(fd_.get(), I2C_SMBUS, &arg) < 0) return errno;
  }
  std::array<uint8_t, 34> out{};
  switch (op.size) {
    case SmbusSize::kByte:
    case SmbusSize::kByteData:
      out[0] = data.byte;
      break;
    case SmbusSize::kWordData:
    case SmbusSize::kProcCall:
      out[0] = static_cast<uint8_t>(data.word & 0xFF);
      out[1] = static_cast<uint8_t>(data.word >> 8);
      break;
    default:
      std::memcpy(out.data(), data.block, out.size());
      break;
  }
  return deliver_reply(op, out, msgs);
}

int LinuxI2cDev::quick(uint16_t addr, bool read) {
  if (!(funcs_ & kFuncSmbusQuick)) return EOPNOTSUPP;
  base::MutexLock lock(mu_);
  if (::ioctl(fd_.get(), I2C_SLAVE_FORCE, static_cast<unsigned long>(addr)) < 0) return errno;
  i2c_smbus_ioctl_data arg{};
  arg.read_write = read ? I2C_SMBUS_READ : I2C_SMBUS_WRITE;
  arg.size = I2C_SMBUS_QUICK;
  if (::ioctl(fd_.get(), I2C_SMBUS, &arg) < 0) return errno;
  return 0;
}

}  // namespace contego::bus
