// Bus backends: where the trusted side performs the transfers it has checked.
// A backend sees only bytes that the trusted side produced from its own copy
// (a verdict's emits, or a read it allowed); it never sees a task's memory.
//
// Thread-safety: implementations serialise their own calls (one internal
// mutex), so a monitor may sample sensors and serve clients concurrently.
#ifndef CONTEGO_BUS_BUS_H_
#define CONTEGO_BUS_BUS_H_

#include <cstdint>
#include <span>

#include "contego/i2c_msg_flags.h"

#include "base/result.h"

namespace contego::bus {

// I2C_FUNCS bits (<linux/i2c.h>).
inline constexpr uint64_t kFuncI2c = 0x00000001;
inline constexpr uint64_t kFunc10BitAddr = 0x00000002;
inline constexpr uint64_t kFuncSmbusPec = 0x00000008;
inline constexpr uint64_t kFuncSmbusBlockProcCall = 0x00008000;
inline constexpr uint64_t kFuncSmbusQuick = 0x00010000;
inline constexpr uint64_t kFuncSmbusReadByte = 0x00020000;
inline constexpr uint64_t kFuncSmbusWriteByte = 0x00040000;
inline constexpr uint64_t kFuncSmbusReadByteData = 0x00080000;
inline constexpr uint64_t kFuncSmbusWriteByteData = 0x00100000;
inline constexpr uint64_t kFuncSmbusReadWordData = 0x00200000;
inline constexpr uint64_t kFuncSmbusWriteWordData = 0x00400000;
inline constexpr uint64_t kFuncSmbusProcCall = 0x00800000;
inline constexpr uint64_t kFuncSmbusAllByteWord = 0x00FE0000;  // byte .. proc call
inline constexpr uint64_t kFuncSmbusReadBlock = 0x01000000;
inline constexpr uint64_t kFuncSmbusWriteBlock = 0x02000000;
inline constexpr uint64_t kFuncSmbusReadI2cBlock = 0x04000000;
inline constexpr uint64_t kFuncSmbusWriteI2cBlock = 0x08000000;
inline constexpr uint64_t kFuncSmbusI2cBlock = 0x0C000000;

// What Linux's i2c-stub reports by default: an SMBus-only adapter with
// quick, byte, byte data, word data and I2C block (no plain I2C, no SMBus
// block, no process calls).
inline constexpr uint64_t kI2cStubFuncs =
    kFuncSmbusQuick | kFuncSmbusReadByte | kFuncSmbusWriteByte | kFuncSmbusReadByteData |
    kFuncSmbusWriteByteData | kFuncSmbusReadWordData | kFuncSmbusWriteWordData | kFuncSmbusI2cBlock;

// Message flags (<linux/i2c.h> i2c_msg.flags): a read, a ten-bit address,
// and a read whose first byte counts the bytes after it.
inline constexpr uint16_t kMsgRead = 0x0001;     // I2C_M_RD
inline constexpr uint16_t kMsgTen = 0x0010;      // I2C_M_TEN
inline constexpr uint16_t kMsgRecvLen = 0x0400;  // I2C_M_RECV_LEN

// One message of a combined transfer. For a read, `buf` receives up to `len`
// bytes and `len` is updated to the number received (RECV_LEN: 1 + count).
struct Msg {
  uint16_t addr = 0;
  uint16_t flags = 0;  // kMsgRead, kMsgTen, kMsgRecvLen
  uint16_t len = 0;
  uint8_t* buf = nullptr;
};

// Whether any message carries a flag outside the allow-list
// (contego/i2c_msg_flags.h): every Bus refuses such a transfer with EINVAL
// before anything reaches the wire.
inline bool carries_refused_flags(std::span<const Msg> msgs) {
  for (const Msg& m : msgs) {
    if (contego_i2c_refused_flags(m.flags) != 0) return true;
  }
  return false;
}

class Bus {
 public:
  virtual ~Bus() = default;
  // The adapter's I2C_FUNCS mask.
  virtual uint64_t funcs() const = 0;
  // One combined transfer (repeated starts between messages). 0 or an errno:
  // ENXIO/EREMOTEIO when an address does not acknowledge.
  virtual int transfer(std::span<Msg> msgs) = 0;
  // SMBus quick command: the address and the R/W bit only.
  virtual int quick(uint16_t addr, bool read) = 0;
  // Whether the adapter can put this combined transfer on the wire as it
  // stands: as plain I2C, or as one SMBus transaction with exactly the same
  // bytes (bus/smbus_plan.h). If not, the error says why (for the audit log)
  // and transfer() would answer EOPNOTSUPP before anything reaches the wire.
  // Callers ask first when other parts of an operation (the checker's
  // decision, earlier messages) must not act either. A quick command is a
  // zero-length message (read flag for a quick read). Only the bytes of
  // write messages are looked at; a read message's buf may be null.
  // Default: plan_transfer() over funcs().
  virtual Status expressible(std::span<const Msg> msgs) const;
};

}  // namespace contego::bus

#endif  // CONTEGO_BUS_BUS_H_
