#include "gate/transfer.h"

#include <climits>
#include <gtest/gtest.h>

namespace contego::gate {
namespace {

Message w(uint16_t addr, std::vector<uint8_t> bytes) {
  Message m;
  m.addr = addr;
  m.len = static_cast<uint16_t>(bytes.size());
  m.data = std::move(bytes);
  return m;
}

Message r(uint16_t addr, uint16_t len) {
  Message m;
  m.addr = addr;
  m.flags = kMsgRead;
  m.len = len;
  return m;
}

// The transactions of a transfer of `messages`.
auto transactions_of(std::vector<Message> messages) {
  Transfer t;
  t.messages = std::move(messages);
  return to_transactions(t);
}

TEST(ToTransactions, OneBytePointerBeforeReadBecomesRegisterRead) {
  auto txs = transactions_of({w(0x40, {0x00}), r(0x40, 1)});
  ASSERT_EQ(txs.size(), 1u);
  EXPECT_EQ(txs[0].kind, core::TxKind::kRead);
  EXPECT_EQ(txs[0].bytes, std::vector<uint8_t>{0x00});
  EXPECT_EQ(txs[0].message_count, 2u);
}

TEST(ToTransactions, EveryWriteInsideACombinedTransferIsCheckedAsAWrite) {
  // The smuggling attack: a real command hidden between reads.
  auto txs = transactions_of(
      {r(0x40, 1), w(0x40, {0xFE, 0x03}), w(0x08, {0x01, 0x77, 0, 0, 0}), r(0x08, 1)});
  ASSERT_EQ(txs.size(), 4u);
  EXPECT_EQ(txs[0].kind, core::TxKind::kRead);
  EXPECT_EQ(txs[1].kind, core::TxKind::kWrite);
  EXPECT_EQ(txs[1].bytes, (std::vector<uint8_t>{0xFE, 0x03}));
  EXPECT_EQ(txs[2].kind, core::TxKind::kWrite);
  EXPECT_EQ(txs[2].addr, 0x08);
  EXPECT_EQ(txs[3].kind, core::TxKind::kRead);
}

TEST(ToTransactions, PointerToAnotherAddressIsAWrite) {
  auto txs = transactions_of({w(0x40, {0x06}), r(0x41, 1)});
  ASSERT_EQ(txs.size(), 2u);
  EXPECT_EQ(txs[0].kind, core::TxKind::kWrite);
}

TEST(ToTransactions, GeneralCallByteIsNeverAPointer) {
  // 0x06 to address 0 resets every PCA9685 on the bus, even if a read follows.
  auto txs = transactions_of({w(0x00, {0x06}), r(0x00, 1)});
  ASSERT_EQ(txs.size(), 2u);
  EXPECT_EQ(txs[0].kind, core::TxKind::kWrite);
  EXPECT_EQ(txs[0].addr, 0);
}

TEST(IsProbe, ScansAndReadsAreProbesWritesAreNot) {
  Transfer quick;
  quick.quick = true;  // i2cdetect's default probe
  EXPECT_TRUE(is_probe(quick));
  Transfer read_byte;
  read_byte.messages = {r(0x50, 1)};  // i2cdetect at 0x50..0x5f
  EXPECT_TRUE(is_probe(read_byte));
  Transfer register_read;
  register_read.messages = {w(0x40, {0x00}), r(0x40, 1)};  // i2cdump, i2cget
  EXPECT_TRUE(is_probe(register_read));
  Transfer write;
  write.messages = {w(0x40, {0x00, 0x11})};
  EXPECT_FALSE(is_probe(write));
  Transfer send_byte;
  send_byte.messages = {w(0x00, {0x06})};  // a one-byte command (software reset) actuates
  EXPECT_FALSE(is_probe(send_byte));
  Transfer hidden;
  hidden.messages = {r(0x40, 1), w(0x40, {0x06, 0x00, 0x00, 0xA4, 0x01}), r(0x40, 1)};
  EXPECT_FALSE(is_probe(hidden));
  Transfer pointer_elsewhere;
  pointer_elsewhere.messages = {w(0x40, {0x00}), r(0x41, 1)};
  EXPECT_FALSE(is_probe(pointer_elsewhere));
  EXPECT_FALSE(is_probe(Transfer{}));
}

TEST(ToTransactions, QuickIsOneQuickTransaction) {
  Transfer t;
  t.quick = true;
  t.quick_addr = 0x40;
  auto txs = to_transactions(t);
  ASSERT_EQ(txs.size(), 1u);
  EXPECT_EQ(txs[0].kind, core::TxKind::kQuick);
  EXPECT_EQ(txs[0].addr, 0x40);
}

TEST(Validate, RefusesKernelLimits) {
  Transfer t;
  EXPECT_FALSE(validate(t).ok());  // no messages
  t.messages.assign(43, r(0x40, 1));
  EXPECT_FALSE(validate(t).ok());
  t.messages.assign(42, r(0x40, 1));
  EXPECT_TRUE(validate(t).ok());
  t.messages = {r(0x40, 8193)};
  EXPECT_FALSE(validate(t).ok());
  t.messages = {w(0x80, {1})};
  EXPECT_FALSE(validate(t).ok());
  Message bad = w(0x40, {1, 2});
  bad.len = 5;
  t.messages = {bad};
  EXPECT_FALSE(validate(t).ok());
  // I2C_RETRIES and I2C_TIMEOUT within i2c-dev's limits only.
  t.messages = {r(0x40, 1)};
  t.timing = {true, INT_MAX, INT_MAX / 10};
  EXPECT_TRUE(validate(t).ok());
  t.timing.timeout_10ms = INT_MAX / 10 + 1;
  EXPECT_FALSE(validate(t).ok());
  t.timing = {true, uint32_t{INT_MAX} + 1, 0};
  EXPECT_FALSE(validate(t).ok());
}

// What a client sends over the wire meets the same allow-list as a program's
// ioctl (contego/i2c_msg_flags.h), and the refusal names the flag.
TEST(Validate, RefusesProtocolManglingFlagsAndNamesThem) {
  Transfer t;
  Message pointer = w(0x40, {0xFF});
  Message read = r(0x40, 2);
  read.flags = static_cast<uint16_t>(kMsgRead | 0x2000);  // I2C_M_REV_DIR_ADDR
  t.messages = {pointer, read};
  EXPECT_NE(validate(t).error().find("message 1: flag I2C_M_REV_DIR_ADDR is not allowed"),
            std::string::npos)
      << validate(t).error();
  for (const int flag : {0x4000, 0x1000, 0x0800, 0x8000, 0x0200, 0x0100, 0x0002}) {
    read.flags = static_cast<uint16_t>(kMsgRead | flag);
    t.messages = {pointer, read};
    EXPECT_FALSE(validate(t).ok()) << flag;
    pointer.flags = static_cast<uint16_t>(flag);
    t.messages = {pointer};
    EXPECT_FALSE(validate(t).ok()) << flag;
    pointer.flags = 0;
  }
  read.flags = static_cast<uint16_t>(kMsgRead | kMsgTen);
  t.messages = {read};
  EXPECT_TRUE(validate(t).ok());
}

}  // namespace
}  // namespace contego::gate
