#include "intercept/i2c_abi/i2c_abi.h"

#include <errno.h>

#include <cstring>
#include <span>

#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

namespace contego::intercept::i2c_abi {
namespace {

// LP64 layouts (offsets verified against <linux/i2c.h> on x86_64 and aarch64).
struct RawMsg {
  uint16_t addr;
  uint16_t flags;
  uint16_t len;
  uint16_t pad;
  uint64_t buf;
};
static_assert(sizeof(RawMsg) == 16);

struct RawRdwr {
  uint64_t msgs;
  uint32_t nmsgs;
  uint32_t pad;
};
static_assert(sizeof(RawRdwr) == 16);

struct RawSmbus {
  uint8_t read_write;
  uint8_t command;
  uint8_t pad[2];
  uint32_t size;
  uint64_t data;
};
static_assert(sizeof(RawSmbus) == 16);

Decoded ret(int64_t value) {
  Decoded d;
  d.value = value;
  return d;
}

Decoded fail(int err) {
  Decoded d;
  d.err = err;
  return d;
}

// A call the trusted side performs: on the descriptor's bus, with its own
// I2C_RETRIES/I2C_TIMEOUT once it set them.
Decoded transfer_on(const FdState& s) {
  Decoded d;
  d.action = Decoded::Action::kTransfer;
  d.transfer.bus = s.bus;
  d.transfer.timing = {s.own_timing, s.retries, s.timeout_10ms};
  return d;
}

gate::Message write_msg(const FdState& s, std::vector<uint8_t> bytes) {
  gate::Message m;
  m.addr = s.addr;
  m.flags = s.ten_bit ? gate::kMsgTen : 0;
  m.len = static_cast<uint16_t>(bytes.size());
  m.data = std::move(bytes);
  return m;
}

gate::Message read_msg(const FdState& s, uint16_t len, uint16_t extra_flags = 0) {
  gate::Message m;
  m.addr = s.addr;
  m.flags = static_cast<uint16_t>(gate::kMsgRead | (s.ten_bit ? gate::kMsgTen : 0) | extra_flags);
  m.len = len;
  return m;
}

Decoded decode_smbus(const FdState& s, uint64_t arg, Memory& memory, uint64_t funcs) {
  RawSmbus a{};
  if (!memory.read(arg, &a, sizeof a)) return fail(EFAULT);
  uint32_t size = a.size;
  if (size > kSmbusI2cBlockData) return fail(EINVAL);
  if (a.read_write != kSmbusRead && a.read_write != kSmbusWrite) return fail(EINVAL);

  Decoded d = transfer_on(s);
  Completion& c = d.completion;
  c.form = Completion::Form::kSmbus;
  c.smbus_read_write = a.read_write;
  const bool read = a.read_write == kSmbusRead;

  // Quick and byte-write use no data (the kernel does not look at the pointer).
  if (size == kSmbusQuick) {
    d.transfer.quick = true;
    d.transfer.quick_read = read;
    d.transfer.quick_addr = s.addr;
    d.transfer.quick_ten_bit = s.ten_bit;
    c.smbus_size = size;
    return d;
  }
  if (a.data == 0 && !(size == kSmbusByte && !read)) return fail(EINVAL);
  size_t datasize = kSmbusDataSize;
  if (size == kSmbusByte || size == kSmbusByteData) datasize = 1;
  if (size == kSmbusWordData || size == kSmbusProcCall) datasize = 2;

  // Byte write uses no data (the kernel does not look at the pointer).
  uint8_t data[kSmbusDataSize] = {};
  if (!(size == kSmbusByte && !read) && (size == kSmbusProcCall || size == kSmbusBlockProcCall ||
                                         size == kSmbusI2cBlockData || !read)) {
    if (!memory.read(a.data, data, datasize)) return fail(EFAULT);
  }
  if (size == kSmbusI2cBlockBroken) {
    size = kSmbusI2cBlockData;
    if (read) data[0] = gate::kSmbusBlockMax;
  }
  c.smbus_data = a.data;
  c.smbus_size = size;
  c.smbus_datasize = size == kSmbusByte && !read ? 0 : datasize;
  if (size == kSmbusProcCall || size == kSmbusBlockProcCall) c.smbus_read_write = kSmbusRead;
  if (size == kSmbusI2cBlockData && read) c.smbus_block_len = data[0];

  // The call's messages: the shared model's table (contego/i2c_plan.h), as
  // contego.ko makes them, a write's PEC included where the adapter sends one.
  contego_i2c_msg m[2];
  uint8_t wire[CONTEGO_SMBUS_WIRE_BYTES], rbuf[CONTEGO_SMBUS_DATA_BYTES - 1];
  const uint16_t flags =
      static_cast<uint16_t>((s.ten_bit ? gate::kMsgTen : 0) |
                            (contego_i2c_pec_on_wire(s.pec, funcs) ? CONTEGO_I2C_CLIENT_PEC : 0));
  const int n =
      contego_i2c_smbus_msgs(s.addr, flags, read ? 1 : 0, a.command, size, data, m, wire, rbuf);
  if (n < 0) return fail(EINVAL);
  for (int i = 0; i < n; ++i) {
    gate::Message msg;
    msg.addr = m[i].addr;
    msg.flags = m[i].flags;
    msg.len = m[i].len;
    if (!(m[i].flags & gate::kMsgRead)) msg.data.assign(m[i].buf, m[i].buf + m[i].len);
    d.transfer.messages.push_back(std::move(msg));
  }
  // A read with PEC: its answer ends with the device's (contego/i2c_plan.h).
  c.smbus_pec = (flags & CONTEGO_I2C_CLIENT_PEC) != 0 && c.smbus_read_write == kSmbusRead &&
                contego_i2c_smbus_pec_kept(size, read ? 1 : 0);
  c.smbus_pec_partial = contego_i2c_answer_pec(m, static_cast<uint32_t>(n));
  return d;
}

Decoded decode_rdwr(const FdState& s, uint64_t arg, Memory& memory) {
  RawRdwr a{};
  if (!memory.read(arg, &a, sizeof a)) return fail(EFAULT);
  if (a.msgs == 0 || a.nmsgs == 0) return fail(EINVAL);
  if (a.nmsgs > gate::kMaxMessages) return fail(EINVAL);
  RawMsg raw[gate::kMaxMessages];
  if (!memory.read(a.msgs, raw, a.nmsgs * sizeof(RawMsg))) return fail(EFAULT);

  Decoded d = transfer_on(s);
  d.completion.form = Completion::Form::kRdwr;
  d.completion.count = a.nmsgs;
  for (uint32_t i = 0; i < a.nmsgs; ++i) {
    const RawMsg& r = raw[i];
    if (r.len > gate::kMaxMessageLen) return fail(EINVAL);
    // Protocol-mangling flags would let a checked read act as a write.
    if (contego_i2c_refused_flags(r.flags) != 0) return fail(EINVAL);
    gate::Message m;
    m.addr = r.addr;
    // I2C_RDWR uses each message's own address and flags; the fd's I2C_SLAVE
    // address and TENBIT flag play no part.
    m.flags = r.flags;
    if (r.flags & gate::kMsgRead) {
      m.len = r.len;
      if (r.flags & gate::kMsgRecvLen) {
        uint8_t preset = 0;
        if (r.len < 1 || !memory.read(r.buf, &preset, 1)) return fail(r.len < 1 ? EINVAL : EFAULT);
        if (preset < 1 || r.len < preset + gate::kSmbusBlockMax) return fail(EINVAL);
        m.len = static_cast<uint16_t>(1 + gate::kSmbusBlockMax);
      }
      d.completion.read_bufs.push_back(r.buf);
    } else {
      if (r.flags & gate::kMsgRecvLen) return fail(EINVAL);
      m.data.resize(r.len);
      if (r.len != 0 && !memory.read(r.buf, m.data.data(), r.len)) return fail(EFAULT);
      m.len = r.len;
    }
    // Addresses beyond the 7/10-bit space are the adapter's EINVAL.
    if (m.addr > ((m.flags & gate::kMsgTen) ? 0x3FF : 0x7F)) return fail(EINVAL);
    d.transfer.messages.push_back(std::move(m));
  }
  return d;
}

}  // namespace

Decoded decode_ioctl(FdState& state, unsigned long request, uint64_t arg, Memory& memory,
                     uint64_t funcs, bool (*address_busy)(uint8_t bus, uint16_t addr)) {
  switch (request) {
    case kI2cSlave:
    case kI2cSlaveForce:
      if ((!state.ten_bit && arg > 0x7F) || arg > 0x3FF) return fail(EINVAL);
      if (request == kI2cSlave && address_busy != nullptr &&
          address_busy(state.bus, static_cast<uint16_t>(arg))) {
        return fail(EBUSY);
      }
      state.addr = static_cast<uint16_t>(arg);
      return ret(0);
    case kI2cTenbit:
      state.ten_bit = arg != 0;
      return ret(0);
    case kI2cPec:
      state.pec = arg != 0;
      return ret(0);
    case kI2cFuncs: {
      const uint64_t value = funcs;
      if (!memory.write(arg, &value, sizeof value)) return fail(EFAULT);
      return ret(0);
    }
    case kI2cRetries:
    case kI2cTimeout:  // the descriptor's own, as under contego.ko (gate::Timing)
      if (!contego_i2c_timing_arg_ok(request == kI2cTimeout, arg)) return fail(EINVAL);
      (request == kI2cRetries ? state.retries : state.timeout_10ms) = static_cast<uint32_t>(arg);
      state.own_timing = true;
      return ret(0);
    case kI2cRdwr:
      return decode_rdwr(state, arg, memory);
    case kI2cSmbus:
      return decode_smbus(state, arg, memory, funcs);
    default:
      return fail(ENOTTY);
  }
}

Decoded decode_write(const FdState& state, uint64_t buf, uint64_t count, Memory& memory) {
  if (count > gate::kMaxMessageLen) count = gate::kMaxMessageLen;
  std::vector<uint8_t> bytes(count);
  if (count != 0 && !memory.read(buf, bytes.data(), count)) return fail(EFAULT);
  Decoded d = transfer_on(state);
  d.transfer.messages.push_back(write_msg(state, std::move(bytes)));
  d.completion.form = Completion::Form::kWrite;
  d.completion.count = static_cast<uint32_t>(count);
  return d;
}

Decoded decode_read(const FdState& state, uint64_t buf, uint64_t count) {
  if (count > gate::kMaxMessageLen) count = gate::kMaxMessageLen;
  Decoded d = transfer_on(state);
  d.transfer.messages.push_back(read_msg(state, static_cast<uint16_t>(count)));
  d.completion.form = Completion::Form::kRead;
  d.completion.count = static_cast<uint32_t>(count);
  d.completion.read_buf = buf;
  return d;
}

int64_t complete(const Completion& c, const gate::TransferReply& reply, Memory& memory) {
  if (reply.err != 0) return -reply.err;
  switch (c.form) {
    case Completion::Form::kWrite:
      return c.count;
    case Completion::Form::kRead: {
      if (reply.reads.size() != 1) return -EIO;
      const auto& r = reply.reads[0];
      if (r.size() > c.count) return -EIO;
      if (!r.empty() && !memory.write(c.read_buf, r.data(), r.size())) return -EFAULT;
      return static_cast<int64_t>(r.size());
    }
    case Completion::Form::kRdwr: {
      if (reply.reads.size() != c.read_bufs.size()) return -EIO;
      for (size_t i = 0; i < c.read_bufs.size(); ++i) {
        const auto& r = reply.reads[i];
        if (!r.empty() && !memory.write(c.read_bufs[i], r.data(), r.size())) return -EFAULT;
      }
      return c.count;
    }
    case Completion::Form::kSmbus: {
      if (c.smbus_read_write != kSmbusRead || c.smbus_size == kSmbusQuick) return 0;
      if (reply.reads.size() != 1) return -EIO;
      std::span<const uint8_t> r = reply.reads[0];
      if (c.smbus_pec) {  // as i2c-core's i2c_smbus_check_pec
        if (r.empty()) return -EIO;
        r = r.first(r.size() - 1);
        if (contego_smbus_pec(c.smbus_pec_partial, r.data(), static_cast<uint32_t>(r.size())) !=
            reply.reads[0].back()) {
          return -EBADMSG;
        }
      }
      uint8_t data[kSmbusDataSize] = {};
      switch (c.smbus_size) {
        case kSmbusByte:
        case kSmbusByteData:
          if (r.size() < 1) return -EIO;
          data[0] = r[0];
          break;
        case kSmbusWordData:
        case kSmbusProcCall:
          if (r.size() < 2) return -EIO;
          data[0] = r[0];
          data[1] = r[1];
          break;
        case kSmbusBlockData:
        case kSmbusBlockProcCall:
          if (r.empty() || r[0] > gate::kSmbusBlockMax || r.size() < 1u + r[0]) return -EPROTO;
          std::memcpy(data, r.data(), 1u + r[0]);
          break;
        case kSmbusI2cBlockData:
          if (r.size() < c.smbus_block_len) return -EIO;
          data[0] = c.smbus_block_len;
          std::memcpy(data + 1, r.data(), c.smbus_block_len);
          break;
        default:
          return -EIO;
      }
      if (!memory.write(c.smbus_data, data, c.smbus_datasize)) return -EFAULT;
      return 0;
    }
  }
  return -EIO;
}

bool LocalMemory::read(uint64_t addr, void* dst, size_t len) {
  if (addr == 0) return false;
  std::memcpy(dst, reinterpret_cast<const void*>(addr), len);
  return true;
}

bool LocalMemory::write(uint64_t addr, const void* src, size_t len) {
  if (addr == 0) return false;
  std::memcpy(reinterpret_cast<void*>(addr), src, len);
  return true;
}

}  // namespace contego::intercept::i2c_abi
