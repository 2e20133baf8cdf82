// The translation of combined transfers to SMBus transactions, without a
// kernel. Two kinds of test:
//  - tables: each mapping of bus/smbus_plan.h, the fallbacks when the
//    preferred form is missing from I2C_FUNCS, and the refusals;
//  - an exhaustive check against an independent model of what each SMBus
//    transaction puts on the wire (the SMBus specification's frames): for
//    every transfer shape and every combination of the SMBus bits of
//    I2C_FUNCS, the plan is an SMBus transaction exactly when one the
//    adapter supports puts the same bytes on the wire, and then it is one.
#include "bus/smbus_plan.h"

#include <errno.h>

#include <algorithm>
#include <array>
#include <gtest/gtest.h>
#include <linux/i2c.h>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bus/virtual_bus.h"

namespace contego::bus {
namespace {

constexpr uint64_t kAllSmbus = kFuncSmbusQuick | kFuncSmbusAllByteWord | kFuncSmbusReadBlock |
                               kFuncSmbusWriteBlock | kFuncSmbusI2cBlock | kFuncSmbusBlockProcCall;

// Owns the buffers of a transfer under test.
struct Xfer {
  std::vector<std::vector<uint8_t>> bufs;
  std::vector<Msg> msgs;

  Xfer() = default;
  Xfer(const Xfer& o) : bufs(o.bufs), msgs(o.msgs) { fix(); }
  Xfer& operator=(const Xfer& o) {
    bufs = o.bufs;
    msgs = o.msgs;
    fix();
    return *this;
  }
  Xfer(Xfer&&) noexcept = default;  // moved vectors keep their buffers
  Xfer& operator=(Xfer&&) noexcept = default;

  Xfer& write(std::vector<uint8_t> bytes, uint16_t addr = 0x40, uint16_t flags = 0) {
    bufs.push_back(std::move(bytes));
    msgs.push_back({addr, flags, static_cast<uint16_t>(bufs.back().size()), nullptr});
    return fix();
  }
  Xfer& read(uint16_t len, uint16_t addr = 0x40, uint16_t flags = 0) {
    bufs.emplace_back(std::max<uint16_t>(len, 1), 0);
    msgs.push_back({addr, static_cast<uint16_t>(flags | kMsgRead), len, nullptr});
    return fix();
  }
  Xfer& block_read(uint16_t addr = 0x40) { return read(33, addr, kMsgRecvLen); }
  Xfer& fix() {
    for (size_t i = 0; i < msgs.size(); ++i) msgs[i].buf = bufs[i].data();
    return *this;
  }
  Plan plan(uint64_t funcs) const { return plan_transfer(msgs, funcs); }
};

std::vector<uint8_t> seq(size_t n, uint8_t first = 0x10) {
  std::vector<uint8_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint8_t>(first + i);
  return v;
}

// seq(n) shaped as a block: [command, count, data...] with byte 1 = `count`.
std::vector<uint8_t> counted(size_t n, uint8_t count, uint8_t first = 0x10) {
  auto v = seq(n, first);
  v[1] = count;
  return v;
}

// The constants are the kernel's.
static_assert(kMsgRead == I2C_M_RD && kMsgTen == I2C_M_TEN && kMsgRecvLen == I2C_M_RECV_LEN);
static_assert(kFuncI2c == I2C_FUNC_I2C && kFunc10BitAddr == I2C_FUNC_10BIT_ADDR);
static_assert(kFuncSmbusQuick == I2C_FUNC_SMBUS_QUICK &&
              kFuncSmbusReadByte == I2C_FUNC_SMBUS_READ_BYTE &&
              kFuncSmbusWriteByte == I2C_FUNC_SMBUS_WRITE_BYTE &&
              kFuncSmbusReadByteData == I2C_FUNC_SMBUS_READ_BYTE_DATA &&
              kFuncSmbusWriteByteData == I2C_FUNC_SMBUS_WRITE_BYTE_DATA &&
              kFuncSmbusReadWordData == I2C_FUNC_SMBUS_READ_WORD_DATA &&
              kFuncSmbusWriteWordData == I2C_FUNC_SMBUS_WRITE_WORD_DATA &&
              kFuncSmbusProcCall == I2C_FUNC_SMBUS_PROC_CALL &&
              kFuncSmbusBlockProcCall == I2C_FUNC_SMBUS_BLOCK_PROC_CALL &&
              kFuncSmbusReadBlock == I2C_FUNC_SMBUS_READ_BLOCK_DATA &&
              kFuncSmbusWriteBlock == I2C_FUNC_SMBUS_WRITE_BLOCK_DATA &&
              kFuncSmbusReadI2cBlock == I2C_FUNC_SMBUS_READ_I2C_BLOCK &&
              kFuncSmbusWriteI2cBlock == I2C_FUNC_SMBUS_WRITE_I2C_BLOCK);
static_assert(kI2cStubFuncs ==
              (I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE | I2C_FUNC_SMBUS_BYTE_DATA |
               I2C_FUNC_SMBUS_WORD_DATA | I2C_FUNC_SMBUS_I2C_BLOCK));
static_assert(static_cast<uint32_t>(SmbusSize::kQuick) == I2C_SMBUS_QUICK &&
              static_cast<uint32_t>(SmbusSize::kByte) == I2C_SMBUS_BYTE &&
              static_cast<uint32_t>(SmbusSize::kByteData) == I2C_SMBUS_BYTE_DATA &&
              static_cast<uint32_t>(SmbusSize::kWordData) == I2C_SMBUS_WORD_DATA &&
              static_cast<uint32_t>(SmbusSize::kProcCall) == I2C_SMBUS_PROC_CALL &&
              static_cast<uint32_t>(SmbusSize::kBlockData) == I2C_SMBUS_BLOCK_DATA &&
              static_cast<uint32_t>(SmbusSize::kBlockProcCall) == I2C_SMBUS_BLOCK_PROC_CALL &&
              static_cast<uint32_t>(SmbusSize::kI2cBlockData) == I2C_SMBUS_I2C_BLOCK_DATA);

// --- an independent wire model ----------------------------------------------

// One segment between a (repeated) start and the next: the address, the
// direction, the bytes the master writes, or how many it reads.
struct Segment {
  uint16_t addr = 0;
  bool read = false;
  std::vector<uint8_t> written;
  int read_len = 0;  // -1: count-prefixed (the device says how many follow)
  bool operator==(const Segment&) const = default;
};
using Wire = std::vector<Segment>;

std::optional<Wire> wire_of_msgs(std::span<const Msg> msgs) {
  Wire w;
  for (const Msg& m : msgs) {
    if (m.flags & ~(kMsgRead | kMsgRecvLen)) return std::nullopt;  // not an SMBus frame at all
    Segment s{m.addr, (m.flags & kMsgRead) != 0, {}, 0};
    if (s.read) {
      s.read_len = (m.flags & kMsgRecvLen) ? -1 : m.len;
    } else {
      s.written.assign(m.buf, m.buf + m.len);
    }
    w.push_back(std::move(s));
  }
  return w;
}

// The SMBus specification's frames (section 6.5), from the op alone.
std::optional<Wire> wire_of_op(const SmbusOp& op) {
  const uint16_t a = op.addr;
  const uint8_t c = op.command;
  const auto& d = op.data;
  auto w = [&](std::vector<uint8_t> bytes) { return Segment{a, false, std::move(bytes), 0}; };
  auto r = [&](int len) { return Segment{a, true, {}, len}; };
  auto block = [&](size_t from, size_t n) {
    return std::vector<uint8_t>(d.begin() + static_cast<long>(from),
                                d.begin() + static_cast<long>(from + n));
  };
  switch (op.size) {
    case SmbusSize::kQuick:
      return Wire{op.read ? r(0) : w({})};
    case SmbusSize::kByte:
      return Wire{op.read ? r(1) : w({c})};
    case SmbusSize::kByteData:
      return op.read ? Wire{w({c}), r(1)} : Wire{w({c, d[0]})};
    case SmbusSize::kWordData:
      return op.read ? Wire{w({c}), r(2)} : Wire{w({c, d[0], d[1]})};
    case SmbusSize::kProcCall:
      return Wire{w({c, d[0], d[1]}), r(2)};
    case SmbusSize::kBlockData: {
      if (op.read) return Wire{w({c}), r(-1)};
      if (d[0] < 1 || d[0] > 32) return std::nullopt;
      std::vector<uint8_t> bytes{c};
      auto rest = block(0, 1 + d[0]);
      bytes.insert(bytes.end(), rest.begin(), rest.end());
      return Wire{w(bytes)};
    }
    case SmbusSize::kBlockProcCall: {
      if (d[0] < 1 || d[0] > 32) return std::nullopt;
      std::vector<uint8_t> bytes{c};
      auto rest = block(0, 1 + d[0]);
      bytes.insert(bytes.end(), rest.begin(), rest.end());
      return Wire{w(bytes), r(-1)};
    }
    case SmbusSize::kI2cBlockData: {
      if (d[0] < 1 || d[0] > 32) return std::nullopt;
      if (op.read) return Wire{w({c}), r(d[0])};
      std::vector<uint8_t> bytes{c};
      auto rest = block(1, d[0]);
      bytes.insert(bytes.end(), rest.begin(), rest.end());
      return Wire{w(bytes)};
    }
  }
  return std::nullopt;
}

uint64_t func_of(SmbusSize size, bool read) {
  switch (size) {
    case SmbusSize::kQuick:
      return kFuncSmbusQuick;
    case SmbusSize::kByte:
      return read ? kFuncSmbusReadByte : kFuncSmbusWriteByte;
    case SmbusSize::kByteData:
      return read ? kFuncSmbusReadByteData : kFuncSmbusWriteByteData;
    case SmbusSize::kWordData:
      return read ? kFuncSmbusReadWordData : kFuncSmbusWriteWordData;
    case SmbusSize::kProcCall:
      return kFuncSmbusProcCall;
    case SmbusSize::kBlockData:
      return read ? kFuncSmbusReadBlock : kFuncSmbusWriteBlock;
    case SmbusSize::kBlockProcCall:
      return kFuncSmbusBlockProcCall;
    case SmbusSize::kI2cBlockData:
      return read ? kFuncSmbusReadI2cBlock : kFuncSmbusWriteI2cBlock;
  }
  return 0;
}

// Every SMBus transaction that puts the same bytes on the wire as `msgs`,
// found by filling each form from the bytes naively and keeping those the
// wire model agrees with.
std::vector<SmbusOp> oracle(std::span<const Msg> msgs) {
  std::vector<SmbusOp> out;
  const auto want = wire_of_msgs(msgs);
  if (!want || msgs.empty()) return out;
  std::vector<uint8_t> bytes;
  if (!(msgs[0].flags & kMsgRead)) bytes.assign(msgs[0].buf, msgs[0].buf + msgs[0].len);
  const int reply = (msgs.back().flags & kMsgRead) ? static_cast<int>(msgs.size()) - 1 : -1;
  for (SmbusSize size : {SmbusSize::kQuick, SmbusSize::kByte, SmbusSize::kByteData,
                         SmbusSize::kWordData, SmbusSize::kProcCall, SmbusSize::kBlockData,
                         SmbusSize::kBlockProcCall, SmbusSize::kI2cBlockData}) {
    for (bool read : {false, true}) {
      const bool proc = size == SmbusSize::kProcCall || size == SmbusSize::kBlockProcCall;
      if (proc && read) continue;  // process calls go as I2C_SMBUS_WRITE
      SmbusOp op;
      op.addr = msgs[0].addr;
      op.read = read;
      op.size = size;
      op.reply = (read || proc) && size != SmbusSize::kQuick ? reply : -1;
      if (size != SmbusSize::kQuick && !(size == SmbusSize::kByte && read) && !bytes.empty()) {
        op.command = bytes[0];
      }
      const size_t rest = bytes.empty() ? 0 : bytes.size() - 1;
      if (size == SmbusSize::kI2cBlockData) {
        if (read) {
          op.data[0] = static_cast<uint8_t>(std::min<int>(msgs.back().len, 255));
        } else if (rest <= 33) {
          op.data[0] = static_cast<uint8_t>(rest);
          std::copy_n(bytes.begin() + 1, rest, op.data.begin() + 1);
        }
      } else if (size != SmbusSize::kQuick && size != SmbusSize::kByte &&
                 !(read && size != SmbusSize::kProcCall && size != SmbusSize::kBlockProcCall)) {
        std::copy_n(bytes.begin() + (bytes.empty() ? 0 : 1), std::min<size_t>(rest, 34),
                    op.data.begin());
      }
      const auto got = wire_of_op(op);
      if (got && *got == *want) out.push_back(op);
    }
  }
  return out;
}

// --- tables --------------------------------------------------------------------

struct Row {
  const char* name;
  Xfer xfer;
  uint64_t funcs;
  std::optional<SmbusSize> size;  // nullopt: refused
  bool read = false;
};

void expect_row(const Row& row) {
  SCOPED_TRACE(row.name);
  const Plan p = row.xfer.plan(row.funcs);
  if (!row.size) {
    EXPECT_EQ(p.form, Plan::Form::kRefused);
    EXPECT_FALSE(p.reason.empty());
    return;
  }
  ASSERT_EQ(p.form, Plan::Form::kSmbus) << p.reason;
  EXPECT_EQ(p.op.size, *row.size) << smbus_name(p.op.size, p.op.read);
  EXPECT_EQ(p.op.read, row.read);
  EXPECT_EQ(p.op.addr, row.xfer.msgs[0].addr);
  // Whatever was chosen puts exactly the transfer's bytes on the wire.
  EXPECT_EQ(wire_of_op(p.op), wire_of_msgs(row.xfer.msgs));
}

TEST(SmbusPlan, EveryMappingOnAFullSmbusAdapter) {
  const uint64_t f = kAllSmbus;
  const Row rows[] = {
      {"quick write", Xfer().write({}), f, SmbusSize::kQuick, false},
      {"quick read", Xfer().read(0), f, SmbusSize::kQuick, true},
      {"send byte", Xfer().write({0x06}), f, SmbusSize::kByte, false},
      {"receive byte", Xfer().read(1), f, SmbusSize::kByte, true},
      {"write byte data", Xfer().write({0x00, 0x21}), f, SmbusSize::kByteData, false},
      {"write word data", Xfer().write({0x06, 0x34, 0x12}), f, SmbusSize::kWordData, false},
      {"I2C block write 3", Xfer().write(seq(4)), f, SmbusSize::kI2cBlockData, false},
      {"I2C block write 32", Xfer().write(seq(33)), f, SmbusSize::kI2cBlockData, false},
      {"SMBus block write of 32 (34 bytes)", Xfer().write(counted(34, 32)), f,
       SmbusSize::kBlockData, false},
      {"read byte data", Xfer().write({0x05}).read(1), f, SmbusSize::kByteData, true},
      {"read word data", Xfer().write({0x05}).read(2), f, SmbusSize::kWordData, true},
      {"I2C block read 3", Xfer().write({0x05}).read(3), f, SmbusSize::kI2cBlockData, true},
      {"I2C block read 32", Xfer().write({0x05}).read(32), f, SmbusSize::kI2cBlockData, true},
      {"SMBus block read", Xfer().write({0x05}).block_read(), f, SmbusSize::kBlockData, true},
      {"process call", Xfer().write({0x05, 0x34, 0x12}).read(2), f, SmbusSize::kProcCall, false},
      {"block process call", Xfer().write({0x05, 2, 0xAA, 0xBB}).block_read(), f,
       SmbusSize::kBlockProcCall, false},
      {"block process call of 32", Xfer().write(counted(34, 32)).block_read(), f,
       SmbusSize::kBlockProcCall, false},
      {"general call send byte (reset)", Xfer().write({0x06}, 0x00), f, SmbusSize::kByte, false},
  };
  for (const Row& row : rows) expect_row(row);
}

TEST(SmbusPlan, GoPiGoFrameIsAnI2cBlockWriteAtRegisterOne) {
  // 01 cmd v1 v2 v3 (the test bed reads it back with i2cget at 0x01..0x04).
  const Xfer x = Xfer().write({0x01, 40, 0, 0, 0}, 0x08);
  const Plan p = x.plan(kI2cStubFuncs);
  ASSERT_EQ(p.form, Plan::Form::kSmbus) << p.reason;
  EXPECT_EQ(p.op.size, SmbusSize::kI2cBlockData);
  EXPECT_EQ(p.op.addr, 0x08);
  EXPECT_EQ(p.op.command, 0x01);
  EXPECT_EQ(p.op.data[0], 4);
  EXPECT_EQ(p.op.data[1], 40);
  // A frame whose second byte happens to count the rest (the line follower's
  // "01 03 00 00 00") stays an I2C block write even where SMBus block exists.
  const Xfer lf = Xfer().write({0x01, 0x03, 0, 0, 0}, 0x06);
  EXPECT_EQ(lf.plan(kAllSmbus).op.size, SmbusSize::kI2cBlockData);
}

TEST(SmbusPlan, FallbacksWhenThePreferredFormIsMissing) {
  const uint64_t f = kAllSmbus;
  const Row rows[] = {
      {"byte data -> I2C block write 1", Xfer().write({0x00, 0x21}), f & ~kFuncSmbusWriteByteData,
       SmbusSize::kI2cBlockData, false},
      {"word data -> I2C block write 2", Xfer().write({0x06, 0x34, 0x12}),
       f & ~kFuncSmbusWriteWordData, SmbusSize::kI2cBlockData, false},
      {"word data -> SMBus block write of 1 when counted", Xfer().write({0x06, 0x01, 0x12}),
       kFuncSmbusWriteBlock, SmbusSize::kBlockData, false},
      {"word data not counted, no word, no I2C block", Xfer().write({0x06, 0x02, 0x12}),
       kFuncSmbusWriteBlock, std::nullopt},
      {"I2C block write -> SMBus block write when counted", Xfer().write({0x06, 3, 1, 2, 3}),
       f & ~kFuncSmbusWriteI2cBlock, SmbusSize::kBlockData, false},
      {"I2C block write not counted, no I2C block", Xfer().write({0x06, 4, 1, 2, 3}),
       f & ~kFuncSmbusWriteI2cBlock, std::nullopt},
      {"read byte data -> I2C block read 1", Xfer().write({0x05}).read(1),
       f & ~kFuncSmbusReadByteData, SmbusSize::kI2cBlockData, true},
      {"read word data -> I2C block read 2", Xfer().write({0x05}).read(2),
       f & ~kFuncSmbusReadWordData, SmbusSize::kI2cBlockData, true},
      {"I2C block read needs its bit", Xfer().write({0x05}).read(3), f & ~kFuncSmbusReadI2cBlock,
       std::nullopt},
      {"block read needs its bit (i2c-stub)", Xfer().write({0x05}).block_read(), kI2cStubFuncs,
       std::nullopt},
      {"process call needs its bit (i2c-stub)", Xfer().write({0x05, 1, 2}).read(2), kI2cStubFuncs,
       std::nullopt},
      {"block process call needs its bit", Xfer().write({0x05, 1, 7}).block_read(),
       f & ~kFuncSmbusBlockProcCall, std::nullopt},
      {"quick needs its bit", Xfer().write({}), f & ~kFuncSmbusQuick, std::nullopt},
      {"send byte needs its bit", Xfer().write({1}), f & ~kFuncSmbusWriteByte, std::nullopt},
      {"receive byte needs its bit", Xfer().read(1), f & ~kFuncSmbusReadByte, std::nullopt},
      {"nothing at all", Xfer().write({0x00, 0x21}), 0, std::nullopt},
  };
  for (const Row& row : rows) expect_row(row);
}

TEST(SmbusPlan, LengthEdges) {
  const uint64_t f = kAllSmbus;
  const Row rows[] = {
      {"write 33 = I2C block of 32", Xfer().write(seq(33)), f, SmbusSize::kI2cBlockData, false},
      {"write 34 not counted", Xfer().write(seq(34)), f, std::nullopt},
      {"write 35 counted 33", Xfer().write(counted(35, 33)), f, std::nullopt},
      {"write 2 with count 0 is byte data, never a block", Xfer().write({0x06, 0x00}),
       kFuncSmbusWriteBlock, std::nullopt},
      {"read 2 without register", Xfer().read(2), f, std::nullopt},
      {"read 3 without register", Xfer().read(3), f, std::nullopt},
      {"read 32 without register", Xfer().read(32), f, std::nullopt},
      {"RECV_LEN without register", Xfer().block_read(), f, std::nullopt},
      {"register + read 0", Xfer().write({0x05}).read(0), f, std::nullopt},
      {"register + read 33", Xfer().write({0x05}).read(33), f, std::nullopt},
      {"empty write + read", Xfer().write({}).read(1), f, std::nullopt},
      {"[c lo hi] + read 1", Xfer().write({0x05, 1, 2}).read(1), f, std::nullopt},
      {"[c lo hi] + read 3", Xfer().write({0x05, 1, 2}).read(3), f, std::nullopt},
      {"[c d] + read 2", Xfer().write({0x05, 1}).read(2), f, std::nullopt},
      {"block proc call with count 0", Xfer().write({0x05, 0}).block_read(), f, std::nullopt},
      {"block proc call count mismatch", Xfer().write({0x05, 3, 1, 2}).block_read(), f,
       std::nullopt},
      {"block proc call of 33", Xfer().write(counted(35, 33)).block_read(), f, std::nullopt},
      {"[c 1 d] + RECV_LEN is a block process call of one byte",
       Xfer().write({0x05, 1, 2}).block_read(), f, SmbusSize::kBlockProcCall, false},
      {"[c lo hi] + RECV_LEN is not a process call", Xfer().write({0x05, 7, 2}).block_read(), f,
       std::nullopt},
  };
  for (const Row& row : rows) expect_row(row);
}

TEST(SmbusPlan, ShapesWithNoSmbusForm) {
  const uint64_t f = kAllSmbus;
  const Row rows[] = {
      {"two writes", Xfer().write({1, 2}).write({3, 4}), f, std::nullopt},
      {"read then write", Xfer().read(1).write({3}), f, std::nullopt},
      {"write + read to another address", Xfer().write({0x05}).read(1, 0x41), f, std::nullopt},
      {"register + two reads", Xfer().write({0x05}).read(1).read(1), f, std::nullopt},
      {"smuggled write", Xfer().write({0x05}).read(1).write({0x00, 0x10}), f, std::nullopt},
      {"ten-bit write", Xfer().write({0x00, 0x21}, 0x123, kMsgTen), f | kFunc10BitAddr,
       std::nullopt},
      {"ten-bit read", Xfer().write({0x00}, 0x123, kMsgTen).read(1, 0x123, kMsgTen),
       f | kFunc10BitAddr, std::nullopt},
      {"IGNORE_NAK", Xfer().write({0x00, 0x21}, 0x40, 0x1000), f, std::nullopt},
      {"NOSTART", Xfer().write({0x00}).write({0x21}, 0x40, 0x4000), f, std::nullopt},
      {"RECV_LEN in a short buffer", Xfer().write({0x05}).read(8, 0x40, kMsgRecvLen), f,
       std::nullopt},
  };
  for (const Row& row : rows) expect_row(row);
}

TEST(SmbusPlan, PlainI2cAdaptersGetEveryTransferAsIs) {
  const uint64_t f = kFuncI2c | kFuncSmbusQuick | kAllSmbus;
  for (const Xfer& x :
       {Xfer().write(seq(200)), Xfer().write({1}).write({2}).read(40), Xfer().read(5),
        Xfer().write({0}, 0x123, kMsgTen).read(2, 0x123, kMsgTen), Xfer().write({})}) {
    EXPECT_EQ(x.plan(f).form, Plan::Form::kI2c);
  }
  // ... except a zero-length message where the driver says it cannot send one.
  const Plan p = Xfer().write({}).plan(kFuncI2c);
  EXPECT_EQ(p.form, Plan::Form::kRefused);
  EXPECT_NE(p.reason.find("zero-length"), std::string::npos);
  EXPECT_EQ(Xfer().read(0).plan(kFuncI2c).form, Plan::Form::kRefused);
  EXPECT_EQ(Xfer().read(3).plan(kFuncI2c).form, Plan::Form::kI2c);
}

TEST(SmbusPlan, RefusalsSayWhatAndWhy) {
  Plan p = Xfer().write({0x05}).block_read().plan(kI2cStubFuncs);
  EXPECT_NE(p.reason.find("[write 1 + read RECV_LEN] at 0x40"), std::string::npos) << p.reason;
  EXPECT_NE(p.reason.find("SMBus block read"), std::string::npos) << p.reason;
  EXPECT_NE(p.reason.find("0x0c7f0000"), std::string::npos) << p.reason;
  p = Xfer().write({0x00, 0x21}).plan(kFuncSmbusQuick);
  EXPECT_NE(p.reason.find("one of write byte data, I2C block write"), std::string::npos)
      << p.reason;
  p = Xfer().write(seq(40), 0x08).plan(kI2cStubFuncs);
  EXPECT_NE(p.reason.find("write 40 at 0x08"), std::string::npos) << p.reason;
  EXPECT_NE(p.reason.find("32 data bytes"), std::string::npos) << p.reason;
}

TEST(SmbusPlan, OperandsAreTheBytesOfTheTransfer) {
  Plan p = Xfer().write({0x06, 0x34, 0x12}).plan(kAllSmbus);
  EXPECT_EQ(p.op.command, 0x06);
  EXPECT_EQ(p.op.data[0], 0x34);  // low byte first on the wire
  EXPECT_EQ(p.op.data[1], 0x12);
  EXPECT_EQ(p.op.reply, -1);
  p = Xfer().write({0x06, 2, 0xAA, 0xBB}).plan(kFuncSmbusWriteBlock);
  EXPECT_EQ(p.op.size, SmbusSize::kBlockData);
  EXPECT_EQ(p.op.data[0], 2);
  EXPECT_EQ(p.op.data[1], 0xAA);
  EXPECT_EQ(p.op.data[2], 0xBB);
  p = Xfer().write({0x06, 2, 0xAA, 0xBB}).plan(kAllSmbus);
  EXPECT_EQ(p.op.size, SmbusSize::kI2cBlockData);
  EXPECT_EQ(p.op.data[0], 3);
  EXPECT_EQ(p.op.data[1], 2);
  EXPECT_EQ(p.op.data[3], 0xBB);
  p = Xfer().write({0x05}).read(7).plan(kAllSmbus);
  EXPECT_EQ(p.op.command, 0x05);
  EXPECT_EQ(p.op.data[0], 7);
  EXPECT_EQ(p.op.reply, 1);
  p = Xfer().read(1).plan(kAllSmbus);
  EXPECT_EQ(p.op.reply, 0);
}

// --- exhaustive ------------------------------------------------------------------

std::vector<Xfer> shapes() {
  std::vector<Xfer> out;
  for (size_t n = 0; n <= 36; ++n) {
    out.push_back(Xfer().write(seq(n, 0x80)));  // never count-shaped (byte 1 >= 0x81)
    if (n >= 2) {
      out.push_back(Xfer().write(counted(n, static_cast<uint8_t>(n - 2), 0x80)));
    }
  }
  for (int n : {0, 1, 2, 3, 31, 32, 33, 34}) out.push_back(Xfer().read(static_cast<uint16_t>(n)));
  out.push_back(Xfer().block_read());
  for (size_t w : {0, 1, 2, 3, 4, 33, 34, 35}) {
    for (bool counted : {false, true}) {
      auto v = seq(w, 0x80);
      if (w >= 2) v[1] = counted ? static_cast<uint8_t>(w - 2) : v[1];
      if (w < 2 && counted) continue;
      for (int n : {0, 1, 2, 3, 32, 33})
        out.push_back(Xfer().write(v).read(static_cast<uint16_t>(n)));
      out.push_back(Xfer().write(v).block_read());
    }
  }
  out.push_back(Xfer().write({1}).read(1, 0x41));
  out.push_back(Xfer().write({1}).write({2}));
  out.push_back(Xfer().read(1).read(1));
  out.push_back(Xfer().write({1}).read(1).read(1));
  out.push_back(Xfer().write({1, 2}, 0x123, kMsgTen));
  out.push_back(Xfer().read(1, 0x40, 0x0800));
  return out;
}

TEST(SmbusPlan, ExhaustiveAgainstTheWireModel) {
  // Every combination of the SMBus bits of I2C_FUNCS (13 bits: 8192 masks).
  const uint64_t bits[] = {
      kFuncSmbusQuick,         kFuncSmbusReadByte,      kFuncSmbusWriteByte,
      kFuncSmbusReadByteData,  kFuncSmbusWriteByteData, kFuncSmbusReadWordData,
      kFuncSmbusWriteWordData, kFuncSmbusProcCall,      kFuncSmbusReadBlock,
      kFuncSmbusWriteBlock,    kFuncSmbusReadI2cBlock,  kFuncSmbusWriteI2cBlock,
      kFuncSmbusBlockProcCall};
  constexpr size_t kBits = sizeof bits / sizeof bits[0];
  size_t smbus = 0, refused = 0, expressible_somewhere = 0;
  for (const Xfer& x : shapes()) {
    const std::vector<SmbusOp> forms = oracle(x.msgs);
    if (!forms.empty()) ++expressible_somewhere;
    // With plain I2C the same transfer always goes as it is.
    ASSERT_EQ(x.plan(kFuncI2c | kAllSmbus).form, Plan::Form::kI2c);
    for (uint32_t combo = 0; combo < (1u << kBits); ++combo) {
      // A shape no SMBus transaction carries is refused under every mask;
      // the empty, full and one-bit masks are enough to show it (and keep
      // the test fast).
      if (forms.empty() && combo != (1u << kBits) - 1 && (combo & (combo - 1)) != 0) continue;
      uint64_t funcs = 0;
      for (size_t b = 0; b < kBits; ++b) {
        if (combo & (1u << b)) funcs |= bits[b];
      }
      const Plan p = x.plan(funcs);
      bool supported = false;
      for (const SmbusOp& op : forms) supported |= (funcs & func_of(op.size, op.read)) != 0;
      if (!supported) {
        ASSERT_EQ(p.form, Plan::Form::kRefused)
            << "funcs " << std::hex << funcs << ": " << smbus_name(p.op.size, p.op.read);
        ASSERT_FALSE(p.reason.empty());
        ++refused;
        continue;
      }
      ASSERT_EQ(p.form, Plan::Form::kSmbus) << "funcs " << std::hex << funcs << ": " << p.reason;
      ASSERT_NE(funcs & func_of(p.op.size, p.op.read), 0u);
      ASSERT_EQ(wire_of_op(p.op), wire_of_msgs(x.msgs)) << smbus_name(p.op.size, p.op.read);
      bool among = false;
      for (const SmbusOp& op : forms) among |= op == p.op;
      ASSERT_TRUE(among) << smbus_name(p.op.size, p.op.read);
      ++smbus;
    }
  }
  RecordProperty("plans_smbus", static_cast<int>(smbus));
  RecordProperty("plans_refused", static_cast<int>(refused));
  EXPECT_GT(expressible_somewhere, 40u);
  EXPECT_GT(smbus, 100000u);
  EXPECT_GT(refused, 100000u);
}

// --- results -----------------------------------------------------------------------

TEST(SmbusPlan, RepliesLandInTheReadMessage) {
  std::array<uint8_t, 34> data{};
  data[0] = 0x34;
  data[1] = 0x12;
  Xfer x = Xfer().write({0x05}).read(2);
  Plan p = x.plan(kAllSmbus);
  ASSERT_EQ(p.op.size, SmbusSize::kWordData);
  EXPECT_EQ(deliver_reply(p.op, data, x.msgs), 0);
  EXPECT_EQ(x.msgs[1].len, 2);
  EXPECT_EQ(x.bufs[1], (std::vector<uint8_t>{0x34, 0x12}));

  x = Xfer().read(1);
  p = x.plan(kAllSmbus);
  EXPECT_EQ(deliver_reply(p.op, data, x.msgs), 0);
  EXPECT_EQ(x.bufs[0][0], 0x34);

  // SMBus block read: count-prefixed, as I2C_M_RECV_LEN leaves it.
  x = Xfer().write({0x05}).block_read();
  p = x.plan(kAllSmbus);
  data = {};
  data[0] = 3;
  data[1] = 0xA;
  data[2] = 0xB;
  data[3] = 0xC;
  EXPECT_EQ(deliver_reply(p.op, data, x.msgs), 0);
  EXPECT_EQ(x.msgs[1].len, 4);
  EXPECT_EQ(x.bufs[1][0], 3);
  EXPECT_EQ(x.bufs[1][3], 0xC);
  for (int bad : {0, 33, 200}) {
    data[0] = static_cast<uint8_t>(bad);
    EXPECT_EQ(deliver_reply(p.op, data, x.msgs), EPROTO) << bad;
  }

  // I2C block read: the driver's count in block[0], never more than asked.
  x = Xfer().write({0x05}).read(4);
  p = x.plan(kAllSmbus);
  data = {};
  data[0] = 4;
  data[1] = 1;
  data[4] = 4;
  EXPECT_EQ(deliver_reply(p.op, data, x.msgs), 0);
  EXPECT_EQ(x.msgs[1].len, 4);
  EXPECT_EQ(x.bufs[1], (std::vector<uint8_t>{1, 0, 0, 4}));
  data[0] = 5;
  EXPECT_EQ(deliver_reply(p.op, data, x.msgs), EPROTO);

  // A write has nothing to deliver.
  x = Xfer().write({0x00, 0x21});
  EXPECT_EQ(deliver_reply(x.plan(kAllSmbus).op, data, x.msgs), 0);
}

// --- the bus interface ---------------------------------------------------------------

class Echo final : public DeviceModel {
 public:
  bool answers(uint16_t addr) const override { return addr == 0x40; }
  void write(uint16_t, std::span<const uint8_t> bytes) override {
    last.assign(bytes.begin(), bytes.end());
  }
  void read(uint16_t, std::span<uint8_t> out) override {
    for (auto& b : out) b = 0x5A;
  }
  std::vector<uint8_t> last;
};

TEST(SmbusPlan, VirtualBusAsAnSmbusOnlyAdapterRefusesBeforeTheDevice) {
  VirtualBus bus;
  auto echo = std::make_shared<Echo>();
  bus.attach(echo);
  Xfer big = Xfer().write(seq(40));
  EXPECT_TRUE(bus.expressible(big.msgs).ok());
  bus.set_funcs(kI2cStubFuncs);
  EXPECT_EQ(bus.funcs(), kI2cStubFuncs);
  const Status s = bus.expressible(big.msgs);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("write 40 at 0x40"), std::string::npos) << s.error();
  EXPECT_EQ(bus.transfer(big.msgs), EOPNOTSUPP);
  EXPECT_EQ(bus.operations(), 0u);
  EXPECT_TRUE(echo->last.empty());
  // What the stub can express goes through, with the same bytes.
  Xfer ok = Xfer().write({0x01, 40, 0, 0, 0});
  EXPECT_EQ(bus.transfer(ok.msgs), 0);
  EXPECT_EQ(echo->last, (std::vector<uint8_t>{0x01, 40, 0, 0, 0}));
  Xfer rd = Xfer().write({0x05}).read(2);
  EXPECT_EQ(bus.transfer(rd.msgs), 0);
  EXPECT_EQ(rd.bufs[1], (std::vector<uint8_t>{0x5A, 0x5A}));
  EXPECT_EQ(bus.quick(0x40, false), 0);
  bus.set_funcs(kI2cStubFuncs & ~kFuncSmbusQuick);
  EXPECT_EQ(bus.quick(0x40, false), EOPNOTSUPP);
}

}  // namespace
}  // namespace contego::bus
