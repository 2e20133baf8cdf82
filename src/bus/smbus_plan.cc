#include "bus/smbus_plan.h"

#include <errno.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <initializer_list>

namespace contego::bus {
namespace {

constexpr uint16_t kBlockMax = 32;

struct Candidate {
  uint64_t func;
  SmbusSize size;
};

std::string hex(uint64_t v, int width = 2) {
  char buf[24];
  (void)std::snprintf(buf, sizeof buf, "0x%0*llx", width, static_cast<unsigned long long>(v));
  return buf;
}

Plan refuse(std::string reason) {
  Plan p;
  p.form = Plan::Form::kRefused;
  p.reason = std::move(reason);
  return p;
}

// A human description of the transfer, for refusals.
std::string describe(std::span<const Msg> msgs) {
  std::string out;
  for (const Msg& m : msgs) {
    if (!out.empty()) out += " + ";
    out += (m.flags & kMsgRead) ? "read " : "write ";
    out += (m.flags & kMsgRecvLen) ? std::string("RECV_LEN") : std::to_string(m.len);
  }
  return (msgs.size() == 1 ? "" : "[") + out + (msgs.size() == 1 ? "" : "]") + " at " +
         hex(msgs.empty() ? 0 : msgs[0].addr);
}

// The first candidate the adapter supports, or a refusal naming them all.
Plan choose(std::span<const Msg> msgs, uint64_t funcs, bool read,
            std::span<const Candidate> candidates, SmbusOp* op) {
  for (const Candidate& c : candidates) {
    if (funcs & c.func) {
      Plan p;
      p.form = Plan::Form::kSmbus;
      p.op = *op;
      p.op.size = c.size;
      return p;
    }
  }
  std::string names;
  for (const Candidate& c : candidates) {
    if (!names.empty()) names += ", ";
    names += smbus_name(c.size, read);
  }
  return refuse(describe(msgs) + ": the adapter has no plain I2C and no " +
                (candidates.size() == 1 ? "" : "one of ") + names + " (I2C_FUNCS " + hex(funcs, 8) +
                ")");
}

Plan choose(std::span<const Msg> msgs, uint64_t funcs, bool read,
            std::initializer_list<Candidate> candidates, SmbusOp* op) {
  return choose(msgs, funcs, read, std::span(candidates.begin(), candidates.size()), op);
}

// The forms that carry `len` data bytes after the command byte, preferred
// first: byte or word data (1 or 2 bytes), the I2C block, then the SMBus
// block if `counted` (a write whose byte 1 counts the bytes after it).
std::span<const Candidate> data_forms(bool read, size_t len, bool counted,
                                      std::array<Candidate, 3>& out) {
  size_t k = 0;
  if (len == 1) {
    out[k++] = {read ? kFuncSmbusReadByteData : kFuncSmbusWriteByteData, SmbusSize::kByteData};
  } else if (len == 2) {
    out[k++] = {read ? kFuncSmbusReadWordData : kFuncSmbusWriteWordData, SmbusSize::kWordData};
  }
  out[k++] = {read ? kFuncSmbusReadI2cBlock : kFuncSmbusWriteI2cBlock, SmbusSize::kI2cBlockData};
  if (counted) out[k++] = {kFuncSmbusWriteBlock, SmbusSize::kBlockData};
  return std::span<const Candidate>(out.data(), k);
}

Plan plan_write(std::span<const Msg> msgs, uint64_t funcs) {
  const Msg& m = msgs[0];
  const uint8_t* b = m.buf;
  SmbusOp op;
  op.addr = m.addr;
  const uint16_t n = m.len;
  if (n == 0) return choose(msgs, funcs, false, {{kFuncSmbusQuick, SmbusSize::kQuick}}, &op);
  op.command = b[0];
  if (n == 1) return choose(msgs, funcs, false, {{kFuncSmbusWriteByte, SmbusSize::kByte}}, &op);
  // The count-prefixed SMBus block write is a form of these bytes only when
  // byte 1 is the number of bytes after it (1..32).
  const bool counted = b[1] == n - 2 && n - 2 >= 1 && n - 2 <= kBlockMax;
  Plan p;
  if (n <= 1 + kBlockMax) {
    if (n <= 3) std::copy_n(b + 1, n - 1, op.data.begin());  // byte or word data
    std::array<Candidate, 3> forms;
    p = choose(msgs, funcs, false, data_forms(false, n - 1u, counted, forms), &op);
  } else if (n == 2 + kBlockMax && counted) {
    p = choose(msgs, funcs, false, {{kFuncSmbusWriteBlock, SmbusSize::kBlockData}}, &op);
  } else {
    return refuse(describe(msgs) +
                  ": no SMBus write carries more than a command byte and 32 data bytes "
                  "(33 bytes, or 34 with a block count), and the adapter has no plain I2C");
  }
  if (p.form != Plan::Form::kSmbus) return p;
  SmbusOp& o = p.op;
  if (o.size == SmbusSize::kI2cBlockData) {  // data[0] = length, then the bytes after the command
    o.data = {};
    o.data[0] = static_cast<uint8_t>(n - 1);
    std::copy_n(b + 1, n - 1, o.data.begin() + 1);
  } else if (o.size == SmbusSize::kBlockData) {  // data[0] = count (b[1]), then the data
    o.data = {};
    std::copy_n(b + 1, n - 1, o.data.begin());
  }
  return p;
}

Plan plan_read(std::span<const Msg> msgs, uint64_t funcs) {
  const Msg& r = msgs[0];
  SmbusOp op;
  op.addr = r.addr;
  op.read = true;
  if (r.flags & kMsgRecvLen) {
    return refuse(describe(msgs) +
                  ": a count-prefixed read without a command byte has no SMBus form, and the "
                  "adapter has no plain I2C");
  }
  if (r.len == 0) return choose(msgs, funcs, true, {{kFuncSmbusQuick, SmbusSize::kQuick}}, &op);
  if (r.len == 1) {
    op.reply = 0;
    return choose(msgs, funcs, true, {{kFuncSmbusReadByte, SmbusSize::kByte}}, &op);
  }
  return refuse(describe(msgs) +
                ": a read of more than one byte needs a register byte before it (SMBus has no "
                "other form), and the adapter has no plain I2C");
}

Plan plan_write_read(std::span<const Msg> msgs, uint64_t funcs) {
  const Msg& w = msgs[0];
  const Msg& r = msgs[1];
  const bool recv_len = (r.flags & kMsgRecvLen) != 0;
  SmbusOp op;
  op.addr = w.addr;
  op.reply = 1;
  if (w.len == 0) {
    return refuse(describe(msgs) + ": an empty write before a read has no SMBus form");
  }
  op.command = w.buf[0];
  if (w.len == 1) {
    op.read = true;
    if (recv_len) {
      return choose(msgs, funcs, true, {{kFuncSmbusReadBlock, SmbusSize::kBlockData}}, &op);
    }
    if (r.len == 0 || r.len > kBlockMax) {
      return refuse(describe(msgs) +
                    ": an SMBus read after a command byte returns 1 to 32 bytes, and the "
                    "adapter has no plain I2C");
    }
    std::array<Candidate, 3> forms;
    Plan p = choose(msgs, funcs, true, data_forms(true, r.len, false, forms), &op);
    if (p.form == Plan::Form::kSmbus && p.op.size == SmbusSize::kI2cBlockData) {
      p.op.data[0] = static_cast<uint8_t>(r.len);
    }
    return p;
  }
  // Process calls: the write carries data, the read answers. i2c-dev and
  // i2c-tools send them as I2C_SMBUS_WRITE and get the answer back anyway.
  if (!recv_len && w.len == 3 && r.len == 2) {
    op.data[0] = w.buf[1];
    op.data[1] = w.buf[2];
    return choose(msgs, funcs, false, {{kFuncSmbusProcCall, SmbusSize::kProcCall}}, &op);
  }
  const uint16_t count = w.len - 2;
  if (recv_len && w.buf[1] == count && count >= 1 && count <= kBlockMax) {
    std::copy_n(w.buf + 1, w.len - 1, op.data.begin());
    return choose(msgs, funcs, false, {{kFuncSmbusBlockProcCall, SmbusSize::kBlockProcCall}}, &op);
  }
  return refuse(describe(msgs) +
                ": a read after more than a command byte is an SMBus form only as a process "
                "call ([cmd lo hi] + read 2) or a block process call ([cmd count data] + "
                "RECV_LEN), and the adapter has no plain I2C");
}

}  // namespace

const char* smbus_name(SmbusSize size, bool read) {
  switch (size) {
    case SmbusSize::kQuick:
      return read ? "quick read" : "quick write";
    case SmbusSize::kByte:
      return read ? "receive byte" : "send byte";
    case SmbusSize::kByteData:
      return read ? "read byte data" : "write byte data";
    case SmbusSize::kWordData:
      return read ? "read word data" : "write word data";
    case SmbusSize::kProcCall:
      return "process call";
    case SmbusSize::kBlockData:
      return read ? "SMBus block read" : "SMBus block write";
    case SmbusSize::kBlockProcCall:
      return "block process call";
    case SmbusSize::kI2cBlockData:
      return read ? "I2C block read" : "I2C block write";
  }
  return "?";
}

Plan plan_transfer(std::span<const Msg> msgs, uint64_t funcs) {
  if (msgs.empty()) return refuse("a transfer without messages");
  if (funcs & kFuncI2c) {
    // Drivers that cannot send a zero-length message clear the quick bit
    // (I2C_FUNC_SMBUS_EMUL & ~I2C_FUNC_SMBUS_QUICK); the kernel would refuse
    // such a message only when the transfer is already under way.
    for (const Msg& m : msgs) {
      if (m.len == 0 && !(m.flags & kMsgRecvLen) && !(funcs & kFuncSmbusQuick)) {
        return refuse(describe(msgs) +
                      ": the adapter cannot send a zero-length message (no quick command in "
                      "I2C_FUNCS " +
                      hex(funcs, 8) + ")");
      }
    }
    Plan p;
    p.form = Plan::Form::kI2c;
    return p;
  }
  for (const Msg& m : msgs) {
    if (m.flags & kMsgTen) {
      return refuse(describe(msgs) + ": a ten-bit address needs an adapter with plain I2C");
    }
    if (m.flags & ~(kMsgRead | kMsgRecvLen)) {
      return refuse(describe(msgs) + ": message flags " + hex(m.flags, 4) +
                    " need an adapter with plain I2C");
    }
    if ((m.flags & kMsgRecvLen) && (!(m.flags & kMsgRead) || m.len < 1 + kBlockMax)) {
      return refuse(describe(msgs) + ": RECV_LEN only on a read of a 33-byte buffer");
    }
    if (!(m.flags & kMsgRead) && m.len != 0 && m.buf == nullptr) {
      return refuse(describe(msgs) + ": a write without its bytes");
    }
  }
  if (msgs.size() == 1) {
    return (msgs[0].flags & kMsgRead) ? plan_read(msgs, funcs) : plan_write(msgs, funcs);
  }
  if (msgs.size() == 2 && !(msgs[0].flags & kMsgRead) && (msgs[1].flags & kMsgRead) &&
      msgs[0].addr == msgs[1].addr) {
    return plan_write_read(msgs, funcs);
  }
  return refuse(describe(msgs) +
                ": only one message, or a write then a read of the same address, is an SMBus "
                "transaction, and the adapter has no plain I2C");
}

int deliver_reply(const SmbusOp& op, const std::array<uint8_t, 34>& data, std::span<Msg> msgs) {
  if (op.reply < 0) return 0;
  if (static_cast<size_t>(op.reply) >= msgs.size()) return EINVAL;
  Msg& m = msgs[static_cast<size_t>(op.reply)];
  switch (op.size) {
    case SmbusSize::kByte:
    case SmbusSize::kByteData:
      if (m.len < 1) return EPROTO;
      m.buf[0] = data[0];
      m.len = 1;
      return 0;
    case SmbusSize::kWordData:
    case SmbusSize::kProcCall:
      if (m.len < 2) return EPROTO;
      m.buf[0] = data[0];
      m.buf[1] = data[1];
      m.len = 2;
      return 0;
    case SmbusSize::kI2cBlockData: {
      // The driver says how many it read in block[0] (at most what we asked).
      const uint8_t count = data[0];
      if (count > op.data[0] || count > m.len) return EPROTO;
      std::copy_n(data.begin() + 1, count, m.buf);
      m.len = count;
      return 0;
    }
    case SmbusSize::kBlockData:
    case SmbusSize::kBlockProcCall: {
      const uint8_t count = data[0];
      if (count == 0 || count > kBlockMax || 1u + count > m.len) return EPROTO;
      std::copy_n(data.begin(), 1 + count, m.buf);
      m.len = static_cast<uint16_t>(1 + count);
      return 0;
    }
    case SmbusSize::kQuick:
      return 0;
  }
  return EINVAL;
}

Status Bus::expressible(std::span<const Msg> msgs) const {
  Plan p = plan_transfer(msgs, funcs());
  if (p.form == Plan::Form::kRefused) return make_error(std::move(p.reason));
  return {};
}

}  // namespace contego::bus
