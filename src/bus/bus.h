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

namespace contego::bus {

// I2C_FUNCS bits (<linux/i2c.h>).
inline constexpr uint64_t kFuncI2c = 0x00000001;
inline constexpr uint64_t kFunc10BitAddr = 0x00000002;
inline constexpr uint64_t kFuncSmbusPec = 0x00000008;
inline constexpr uint64_t kFuncSmbusBlockProcCall = 0x00008000;
inline constexpr uint64_t kFuncSmbusQuick = 0x00010000;
inline constexpr uint64_t kFuncSmbusAllByteWord = 0x00FE0000;  // byte .. proc call
inline constexpr uint64_t kFuncSmbusReadBlock = 0x01000000;
inline constexpr uint64_t kFuncSmbusWriteBlock = 0x02000000;
inline constexpr uint64_t kFuncSmbusI2cBlock = 0x0C000000;

// One message of a combined transfer. For a read, `buf` receives up to `len`
// bytes and `len` is updated to the number received (RECV_LEN: 1 + count).
struct Msg {
  uint16_t addr = 0;
  uint16_t flags = 0;  // 0x0001 read, 0x0010 ten-bit, 0x0400 RECV_LEN
  uint16_t len = 0;
  uint8_t* buf = nullptr;
};

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
};

}  // namespace contego::bus

#endif  // CONTEGO_BUS_BUS_H_
