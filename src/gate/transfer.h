// Transfer: one bus operation as the trusted side receives it from an enclave
// client, already copied out of the task's memory. It is the common form of
// write(), read(), every I2C_SMBUS size and I2C_RDWR: a list of I2C messages
// (as struct i2c_msg, but owning its bytes) or an SMBus quick command.
//
// to_transactions() is the one place that turns messages into the trusted
// core's Transactions, so every client and every backend check the same way.
// Host code; allocates.
#ifndef CONTEGO_GATE_TRANSFER_H_
#define CONTEGO_GATE_TRANSFER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "contego/core/transaction.h"
#include "contego/core/verdict.h"

#include "base/result.h"

namespace contego::gate {

// Limits of the Linux i2c-dev ABI (drivers/i2c/i2c-dev.c).
inline constexpr uint32_t kMaxMessages = 42;      // I2C_RDWR_IOCTL_MAX_MSGS
inline constexpr uint32_t kMaxMessageLen = 8192;  // per message and per read()/write()
inline constexpr uint32_t kSmbusBlockMax = 32;    // I2C_SMBUS_BLOCK_MAX

// i2c_msg flags we interpret (values from <linux/i2c.h>).
inline constexpr uint16_t kMsgRead = 0x0001;
inline constexpr uint16_t kMsgTen = 0x0010;
inline constexpr uint16_t kMsgRecvLen = 0x0400;

struct Message {
  uint16_t addr = 0;
  uint16_t flags = 0;         // kMsgRead, kMsgTen, kMsgRecvLen (others refused: validate())
  uint16_t len = 0;           // read: bytes to read (RECV_LEN: 1 + up to 32); write: data.size()
  std::vector<uint8_t> data;  // write payload: the trusted side's own copy
  bool is_read() const { return (flags & kMsgRead) != 0; }
};

// The descriptor's own I2C_RETRIES and I2C_TIMEOUT, once it set either
// (i2c-dev sets them adapter-wide; contego keeps them per descriptor). The
// trusted side tries each acting transfer of the call again on a lost
// arbitration by i2c-core's rule with them (contego_i2c_try_again); without
// them, once. A descriptor that set only one has the other's default: no
// retries, or i2c-core's timeout of an adapter that sets none.
struct Timing {
  bool own = false;
  uint32_t retries = 0;       // I2C_RETRIES: at most INT_MAX
  uint32_t timeout_10ms = 0;  // I2C_TIMEOUT, tens of milliseconds: at most INT_MAX / 10
};

struct Transfer {
  uint8_t bus = 0;
  bool quick = false;  // SMBus quick: no messages, only the address and the R/W bit
  bool quick_read = false;
  uint16_t quick_addr = 0;
  bool quick_ten_bit = false;
  std::vector<Message> messages;  // performed as one combined transfer
  Timing timing;
};

// A transfer that can actuate nothing: an SMBus quick, reads, and one-byte
// register pointers each followed by a read (address scans, i2cdump, sensor
// and status reads). Such transfers are still checked; they only do not
// count against a task's actuation budget.
bool is_probe(const Transfer& t);

// The reply to a transfer: 0 or an errno, and the bytes of every read
// message (in message order; one entry per read message).
struct TransferReply {
  int err = 0;
  std::vector<std::vector<uint8_t>> reads;
};

// One core transaction per bus operation that must be checked, with the
// messages it covers. Rules (docs/gate-protocol.md, "Normalisation"):
//  - every write message is a kWrite transaction of its bytes, except
//  - a write message of exactly one byte followed by a read message to the
//    same address is the register pointer of that read (kRead with that
//    byte): the universal register-read idiom, and the wire form of SMBus
//    BYTE_DATA / WORD_DATA / block reads;
//  - every other read message is a kRead with no pointer bytes;
//  - an SMBus quick is one kQuick.
struct PlannedTx {
  core::TxKind kind = core::TxKind::kWrite;
  uint16_t addr = 0;
  bool ten_bit = false;
  std::vector<uint8_t> bytes;
  uint32_t first_message = 0;  // messages [first_message, first_message + message_count)
  uint32_t message_count = 0;
  // A read that answers the write before it in one combined transfer (a
  // process call: contego_i2c_write_then_read); the two go out together.
  bool answers_write = false;
};

std::vector<PlannedTx> to_transactions(const Transfer& transfer);
// The same into `out`, reusing its elements (the monitor's path: no
// allocation per transfer).
void to_transactions(const Transfer& transfer, std::vector<PlannedTx>& out);

// Structural validity (limits above, lengths consistent): what is wrong, if
// anything; the caller answers EINVAL.
Status validate(const Transfer& transfer);

}  // namespace contego::gate

#endif  // CONTEGO_GATE_TRANSFER_H_
