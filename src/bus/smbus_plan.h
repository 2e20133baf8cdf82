// How a combined I2C transfer reaches an adapter: plain I2C (I2C_RDWR) when
// the adapter has I2C_FUNC_I2C, otherwise the one SMBus transaction
// (I2C_SMBUS) that puts exactly the same bytes on the wire, chosen by the
// adapter's I2C_FUNCS bits; or a refusal with the reason, decided before any
// part of the transfer acts.
//
// Wire forms (S start, Sr repeated start, P stop, A address):
//   [write 0]                      quick write        S A+W P
//   [read 0]                       quick read         S A+R P
//   [write c]                      send byte          S A+W c P
//   [read 1]                       receive byte       S A+R d P
//   [write c d]                    write byte data    (or I2C block write of 1)
//   [write c lo hi]                write word data    (or I2C block write of 2,
//                                                      or SMBus block write if hi == 1)
//   [write c d1..dn], n <= 32      I2C block write    (or SMBus block write if d1 == n-1)
//   [write c 32 d1..d32]           SMBus block write  (only form of 34 bytes)
//   [write c][read 1]              read byte data     (or I2C block read of 1)
//   [write c][read 2]              read word data     (or I2C block read of 2)
//   [write c][read n], 3 <= n <= 32  I2C block read
//   [write c][read RECV_LEN]       SMBus block read
//   [write c lo hi][read 2]        process call
//   [write c k d1..dk][read RECV_LEN], 1 <= k <= 32  block process call
// The raw I2C-block form is preferred over the count-prefixed SMBus block
// form: both put the same bytes on the wire, but only the former is chosen
// for bytes that merely happen to look count-prefixed. Every other shape
// (more than two messages, a read without a register byte longer than one
// byte, different addresses, ten-bit addresses, protocol-mangling flags)
// has no SMBus form and is refused on an adapter without plain I2C.
//
// Pure: no kernel, no allocation beyond the reason text.
#ifndef CONTEGO_BUS_SMBUS_PLAN_H_
#define CONTEGO_BUS_SMBUS_PLAN_H_

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "bus/bus.h"

namespace contego::bus {

// I2C_SMBUS transaction sizes (<linux/i2c.h>).
enum class SmbusSize : uint32_t {
  kQuick = 0,
  kByte = 1,
  kByteData = 2,
  kWordData = 3,
  kProcCall = 4,
  kBlockData = 5,
  kBlockProcCall = 7,
  kI2cBlockData = 8,
};

// One I2C_SMBUS ioctl.
struct SmbusOp {
  uint16_t addr = 0;
  bool read = false;  // read_write: I2C_SMBUS_READ (for quick: the R/W bit)
  uint8_t command = 0;
  SmbusSize size = SmbusSize::kQuick;
  // union i2c_smbus_data as bytes, with the word as [lo, hi] (the byte order
  // on the wire; the executor converts to the host's u16): byte in data[0];
  // word in data[0..1]; block: data[0] = count (I2C block read: bytes
  // wanted), data[1..count] the bytes.
  std::array<uint8_t, 34> data{};
  // The read message that receives the result (-1: none).
  int reply = -1;

  friend bool operator==(const SmbusOp&, const SmbusOp&) = default;
};

struct Plan {
  enum class Form : uint8_t { kI2c, kSmbus, kRefused };
  Form form = Form::kRefused;
  SmbusOp op;          // kSmbus
  std::string reason;  // kRefused: why (the transfer answers EOPNOTSUPP)
};

Plan plan_transfer(std::span<const Msg> msgs, uint64_t funcs);

// Copies the result of a read op (`data` as I2C_SMBUS returned it, word as
// [lo, hi]) into the read message op.reply names, setting its len (RECV_LEN:
// 1 + count). 0, or EPROTO for a block count of 0, above 32 or beyond the
// message's buffer. Nothing to do for a write.
int deliver_reply(const SmbusOp& op, const std::array<uint8_t, 34>& data, std::span<Msg> msgs);

// Human name of an SMBus form ("write byte data", ...), for messages.
const char* smbus_name(SmbusSize size, bool read);

}  // namespace contego::bus

#endif  // CONTEGO_BUS_SMBUS_PLAN_H_
