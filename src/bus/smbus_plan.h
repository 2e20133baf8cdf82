// How a combined I2C transfer reaches an adapter, for the monitor's buses:
// the shared i2c-dev model's planner (contego/i2c_plan.h, which has the
// table of wire forms; contego.ko links the same code), with the reason of a
// refusal as text for the audit log. Plain I2C (I2C_RDWR) when the adapter
// has I2C_FUNC_I2C, otherwise the one SMBus transaction (I2C_SMBUS) that puts
// exactly the same bytes on the wire, or a refusal decided before any part of
// the transfer acts.
//
// Pure: no kernel, no allocation beyond the reason text.
#ifndef CONTEGO_BUS_SMBUS_PLAN_H_
#define CONTEGO_BUS_SMBUS_PLAN_H_

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "contego/i2c_plan.h"

#include "bus/bus.h"

namespace contego::bus {

// I2C_SMBUS transaction sizes: the shared model's (contego_smbus_size), typed.
enum class SmbusSize : uint32_t {
  kQuick = CONTEGO_SMBUS_QUICK,
  kByte = CONTEGO_SMBUS_BYTE,
  kByteData = CONTEGO_SMBUS_BYTE_DATA,
  kWordData = CONTEGO_SMBUS_WORD_DATA,
  kProcCall = CONTEGO_SMBUS_PROC_CALL,
  kBlockData = CONTEGO_SMBUS_BLOCK_DATA,
  kBlockProcCall = CONTEGO_SMBUS_BLOCK_PROC_CALL,
  kI2cBlockData = CONTEGO_SMBUS_I2C_BLOCK_DATA,
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

// The reason of the shared planner's refusal `p` of `msgs` on an adapter
// with `funcs`: the transfer, then why, with the details the planner leaves
// to its host (the forms it lacks, the flags, the funcs). Only the messages'
// addresses, flags and lengths are read (a record of contego.ko's has no
// more: `contego kmod audit` words its refusals with this too).
std::string refusal_reason(std::span<const Msg> msgs, uint64_t funcs, const contego_i2c_plan& p);

// Copies the result of a read op (`data` as I2C_SMBUS returned it, word as
// [lo, hi]) into the read message op.reply names, setting its len (RECV_LEN:
// 1 + count). 0, or EPROTO for a block count of 0, above 32 or beyond the
// message's buffer. Nothing to do for a write.
int deliver_reply(const SmbusOp& op, const std::array<uint8_t, 34>& data, std::span<Msg> msgs);

// Human name of an SMBus form ("write byte data", ...), for messages.
const char* smbus_name(SmbusSize size, bool read);

}  // namespace contego::bus

#endif  // CONTEGO_BUS_SMBUS_PLAN_H_
