// contego/i2c_plan.h: the form of a transfer on an adapter. Freestanding:
// linked into contego.ko as well as the monitor.
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

namespace {

// I2C_FUNCS bits (<linux/i2c.h>).
constexpr uint64_t kFuncI2c = 0x00000001;
constexpr uint64_t kFuncBlockProcCall = 0x00008000;
constexpr uint64_t kFuncQuick = 0x00010000;
constexpr uint64_t kFuncReadByte = 0x00020000;
constexpr uint64_t kFuncWriteByte = 0x00040000;
constexpr uint64_t kFuncReadByteData = 0x00080000;
constexpr uint64_t kFuncWriteByteData = 0x00100000;
constexpr uint64_t kFuncReadWordData = 0x00200000;
constexpr uint64_t kFuncWriteWordData = 0x00400000;
constexpr uint64_t kFuncProcCall = 0x00800000;
constexpr uint64_t kFuncReadBlock = 0x01000000;
constexpr uint64_t kFuncWriteBlock = 0x02000000;
constexpr uint64_t kFuncReadI2cBlock = 0x04000000;
constexpr uint64_t kFuncWriteI2cBlock = 0x08000000;

constexpr uint32_t kBlockMax = CONTEGO_SMBUS_BLOCK_MAX;
constexpr uint16_t kRead = CONTEGO_I2C_M_RD;
constexpr uint16_t kRecvLen = CONTEGO_I2C_M_RECV_LEN;

struct Candidate {
  uint64_t func;
  uint8_t size;
};

// Forms in order of preference; the plan's op already holds everything but
// the size.
class Planner {
 public:
  Planner(uint64_t funcs, contego_i2c_plan* plan) : funcs_(funcs), plan_(plan) {
    *plan_ = contego_i2c_plan{};
    plan_->op.reply = -1;
  }

  void refuse(uint8_t why) {
    plan_->form = CONTEGO_I2C_FORM_REFUSED;
    plan_->refusal = why;
  }

  // The first candidate the adapter supports, or a refusal naming them all.
  void choose(bool read, const Candidate* c, uint32_t n) {
    for (uint32_t i = 0; i < n; ++i) {
      if (funcs_ & c[i].func) {
        plan_->form = CONTEGO_I2C_FORM_SMBUS;
        plan_->op.size = c[i].size;
        return;
      }
    }
    refuse(CONTEGO_I2C_NO_FORM);
    plan_->candidates_read = read ? 1 : 0;
    plan_->candidate_count = static_cast<uint8_t>(n);
    for (uint32_t i = 0; i < n; ++i) plan_->candidates[i] = c[i].size;
  }
  void choose_one(bool read, uint64_t func, uint8_t size) {
    const Candidate c{func, size};
    choose(read, &c, 1);
  }

  // The forms that carry `len` data bytes after the command byte, preferred
  // first: byte or word data (1 or 2 bytes), the I2C block, then the SMBus
  // block if `counted` (a write whose byte 1 counts the bytes after it).
  void choose_data_form(bool read, uint32_t len, bool counted) {
    Candidate c[3];
    uint32_t k = 0;
    if (len == 1) {
      c[k++] = {read ? kFuncReadByteData : kFuncWriteByteData, CONTEGO_SMBUS_BYTE_DATA};
    } else if (len == 2) {
      c[k++] = {read ? kFuncReadWordData : kFuncWriteWordData, CONTEGO_SMBUS_WORD_DATA};
    }
    c[k++] = {read ? kFuncReadI2cBlock : kFuncWriteI2cBlock, CONTEGO_SMBUS_I2C_BLOCK_DATA};
    if (counted) c[k++] = {kFuncWriteBlock, CONTEGO_SMBUS_BLOCK_DATA};
    choose(read, c, k);
  }

  void write(const contego_i2c_msg& m);
  void read(const contego_i2c_msg& r);
  void write_read(const contego_i2c_msg& w, const contego_i2c_msg& r);

  contego_smbus_op& op() { return plan_->op; }

 private:
  uint64_t funcs_;
  contego_i2c_plan* plan_;
};

void copy_bytes(uint8_t* dst, const uint8_t* src, uint32_t n) {
  for (uint32_t i = 0; i < n; ++i) dst[i] = src[i];
}

void Planner::write(const contego_i2c_msg& m) {
  const uint8_t* b = m.buf;
  const uint32_t n = m.len;
  op().addr = m.addr;
  if (n == 0) return choose_one(false, kFuncQuick, CONTEGO_SMBUS_QUICK);
  op().command = b[0];
  if (n == 1) return choose_one(false, kFuncWriteByte, CONTEGO_SMBUS_BYTE);
  // The count-prefixed SMBus block write is a form of these bytes only when
  // byte 1 is the number of bytes after it (1..32).
  const bool counted = b[1] == n - 2 && n - 2 >= 1 && n - 2 <= kBlockMax;
  if (n <= 1 + kBlockMax) {
    choose_data_form(false, n - 1, counted);
  } else if (n == 2 + kBlockMax && counted) {
    choose_one(false, kFuncWriteBlock, CONTEGO_SMBUS_BLOCK_DATA);
  } else {
    return refuse(CONTEGO_I2C_WRITE_TOO_LONG);
  }
  if (plan_->form != CONTEGO_I2C_FORM_SMBUS) return;
  if (op().size ==
      CONTEGO_SMBUS_I2C_BLOCK_DATA) {  // data[0] = length, then the bytes after the command
    op().data[0] = static_cast<uint8_t>(n - 1);
    copy_bytes(op().data + 1, b + 1, n - 1);
  } else {  // byte or word data: the bytes; SMBus block: the count (b[1]), then the data
    copy_bytes(op().data, b + 1, n - 1);
  }
}

void Planner::read(const contego_i2c_msg& r) {
  op().addr = r.addr;
  op().read = 1;
  if (r.flags & kRecvLen) return refuse(CONTEGO_I2C_COUNTED_READ_ALONE);
  if (r.len == 0) return choose_one(true, kFuncQuick, CONTEGO_SMBUS_QUICK);
  if (r.len > 1) return refuse(CONTEGO_I2C_LONG_READ_ALONE);
  op().reply = 0;
  choose_one(true, kFuncReadByte, CONTEGO_SMBUS_BYTE);
}

void Planner::write_read(const contego_i2c_msg& w, const contego_i2c_msg& r) {
  const bool recv_len = (r.flags & kRecvLen) != 0;
  op().addr = w.addr;
  op().reply = 1;
  if (w.len == 0) return refuse(CONTEGO_I2C_EMPTY_POINTER);
  op().command = w.buf[0];
  if (w.len == 1) {
    op().read = 1;
    if (recv_len) return choose_one(true, kFuncReadBlock, CONTEGO_SMBUS_BLOCK_DATA);
    if (r.len == 0 || r.len > kBlockMax) return refuse(CONTEGO_I2C_READ_LENGTH);
    choose_data_form(true, r.len, false);
    if (plan_->form == CONTEGO_I2C_FORM_SMBUS && op().size == CONTEGO_SMBUS_I2C_BLOCK_DATA) {
      op().data[0] = static_cast<uint8_t>(r.len);
    }
    return;
  }
  // Process calls: the write carries data, the read answers. i2c-dev and
  // i2c-tools send them as I2C_SMBUS_WRITE and get the answer back anyway.
  if (!recv_len && w.len == 3 && r.len == 2) {
    op().data[0] = w.buf[1];
    op().data[1] = w.buf[2];
    return choose_one(false, kFuncProcCall, CONTEGO_SMBUS_PROC_CALL);
  }
  const uint32_t count = w.len - 2u;
  if (recv_len && w.buf[1] == count && count >= 1 && count <= kBlockMax) {
    copy_bytes(op().data, w.buf + 1, w.len - 1u);
    return choose_one(false, kFuncBlockProcCall, CONTEGO_SMBUS_BLOCK_PROC_CALL);
  }
  refuse(CONTEGO_I2C_WRITE_READ_SHAPE);
}

}  // namespace

// The functions below keep the C linkage of their declarations in the header.
void contego_i2c_plan_transfer(const contego_i2c_msg* msgs, uint32_t n, uint64_t funcs,
                               contego_i2c_plan* plan) {
  Planner p(funcs, plan);
  if (n == 0) return p.refuse(CONTEGO_I2C_NO_MESSAGES);
  if (funcs & kFuncI2c) {
    // Drivers that cannot send a zero-length message clear the quick bit
    // (I2C_FUNC_SMBUS_EMUL & ~I2C_FUNC_SMBUS_QUICK); the kernel would refuse
    // such a message only when the transfer is already under way.
    for (uint32_t i = 0; i < n; ++i) {
      if (msgs[i].len == 0 && !(msgs[i].flags & kRecvLen) && !(funcs & kFuncQuick)) {
        return p.refuse(CONTEGO_I2C_NO_ZERO_LENGTH);
      }
    }
    plan->form = CONTEGO_I2C_FORM_I2C;
    return;
  }
  for (uint32_t i = 0; i < n; ++i) {
    const contego_i2c_msg& m = msgs[i];
    if (m.flags & CONTEGO_I2C_M_TEN) return p.refuse(CONTEGO_I2C_TEN_BIT);
    if (m.flags & ~(kRead | kRecvLen)) {
      plan->flags = m.flags;
      return p.refuse(CONTEGO_I2C_FLAGS);
    }
    if ((m.flags & kRecvLen) && (!(m.flags & kRead) || m.len < 1 + kBlockMax)) {
      return p.refuse(CONTEGO_I2C_RECV_LEN_SHAPE);
    }
    if (!(m.flags & kRead) && m.len != 0 && m.buf == nullptr) return p.refuse(CONTEGO_I2C_NO_BYTES);
  }
  if (n == 1) return (msgs[0].flags & kRead) ? p.read(msgs[0]) : p.write(msgs[0]);
  if (n == 2 && !(msgs[0].flags & kRead) && (msgs[1].flags & kRead) &&
      msgs[0].addr == msgs[1].addr) {
    return p.write_read(msgs[0], msgs[1]);
  }
  p.refuse(CONTEGO_I2C_SHAPE);
}

int contego_i2c_deliver_reply(const contego_smbus_op* op,
                              const uint8_t data[CONTEGO_SMBUS_DATA_BYTES], contego_i2c_msg* msgs,
                              uint32_t n) {
  constexpr int kEproto = 71, kEinval = 22;  // Linux's errno values
  if (op->reply < 0) return 0;
  if (static_cast<uint32_t>(op->reply) >= n) return kEinval;
  contego_i2c_msg& m = msgs[op->reply];
  uint32_t from = 0, count = 0;
  switch (op->size) {
    case CONTEGO_SMBUS_BYTE:
    case CONTEGO_SMBUS_BYTE_DATA:
      count = 1;
      break;
    case CONTEGO_SMBUS_WORD_DATA:
    case CONTEGO_SMBUS_PROC_CALL:
      count = 2;
      break;
    case CONTEGO_SMBUS_I2C_BLOCK_DATA:
      // The driver says how many it read in block[0] (at most what we asked).
      from = 1;
      count = data[0];
      if (count > op->data[0]) return kEproto;
      break;
    case CONTEGO_SMBUS_BLOCK_DATA:
    case CONTEGO_SMBUS_BLOCK_PROC_CALL:  // the count byte, then the data
      if (data[0] == 0 || data[0] > kBlockMax) return kEproto;
      count = 1u + data[0];
      break;
    case CONTEGO_SMBUS_QUICK:
      return 0;
    default:
      return kEinval;
  }
  if (count > m.len) return kEproto;
  copy_bytes(m.buf, data + from, count);
  m.len = static_cast<uint16_t>(count);
  return 0;
}

const char* contego_smbus_name(uint32_t size, int read) {
  // [size][read]; sizes 6 (BROKEN) and above 8 have no name.
  static const char* const kNames[9][2] = {{"quick write", "quick read"},
                                           {"send byte", "receive byte"},
                                           {"write byte data", "read byte data"},
                                           {"write word data", "read word data"},
                                           {"process call", "process call"},
                                           {"SMBus block write", "SMBus block read"},
                                           {"?", "?"},
                                           {"block process call", "block process call"},
                                           {"I2C block write", "I2C block read"}};
  return size < 9 ? kNames[size][read ? 1 : 0] : "?";
}

const char* contego_i2c_refusal_text(uint32_t refusal) {
  static const char* const kText[] = {
      "",
      "a transfer without messages",
      "the adapter cannot send a zero-length message (no quick command in I2C_FUNCS)",
      "a ten-bit address needs an adapter with plain I2C",
      "these message flags need an adapter with plain I2C",
      "RECV_LEN only on a read of a 33-byte buffer",
      "a write without its bytes",
      "the adapter has no plain I2C and no SMBus form it names",
      "no SMBus write carries more than a command byte and 32 data bytes (33 bytes, or 34 with a "
      "block count), and the adapter has no plain I2C",
      "a count-prefixed read without a command byte has no SMBus form, and the adapter has no "
      "plain I2C",
      "a read of more than one byte needs a register byte before it (SMBus has no other form), and "
      "the adapter has no plain I2C",
      "an empty write before a read has no SMBus form",
      "an SMBus read after a command byte returns 1 to 32 bytes, and the adapter has no plain I2C",
      "a read after more than a command byte is an SMBus form only as a process call ([cmd lo hi] "
      "+ read 2) or a block process call ([cmd count data] + RECV_LEN), and the adapter has no "
      "plain I2C",
      "only one message, or a write then a read of the same address, is an SMBus transaction, and "
      "the adapter has no plain I2C"};
  static_assert(sizeof kText / sizeof kText[0] == CONTEGO_I2C_SHAPE + 1);
  return refusal <= CONTEGO_I2C_SHAPE ? kText[refusal] : "?";
}
