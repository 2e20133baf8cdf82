// The shared normalisation through its C ABI (gate/transfer_test.cc tests it
// through the gate's Transfer).
#include <gtest/gtest.h>
#include <initializer_list>
#include <linux/i2c.h>

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

namespace {

TEST(I2cTransactions, AOneByteWriteBeforeAReadIsItsRegisterPointer) {
  uint8_t reg[1] = {0x06}, r[2] = {}, w[3] = {0x08, 1, 2};
  contego_i2c_msg m[3] = {{0x40, 0, 1, reg}, {0x40, I2C_M_RD, 2, r}, {0x40, 0, 3, w}};
  contego_i2c_tx tx[3];
  ASSERT_EQ(contego_i2c_transactions(m, 3, tx), 2u);
  EXPECT_EQ(tx[0].kind, CONTEGO_TX_READ);
  EXPECT_EQ(tx[0].len, 1u);
  EXPECT_EQ(tx[0].bytes, reg);
  EXPECT_EQ(tx[0].first_msg, 0u);
  EXPECT_EQ(tx[0].msg_count, 2u);
  EXPECT_EQ(tx[1].kind, CONTEGO_TX_WRITE);
  EXPECT_EQ(tx[1].len, 3u);
  EXPECT_EQ(tx[1].first_msg, 2u);
  EXPECT_EQ(tx[1].msg_count, 1u);
}

TEST(I2cTransactions, NoPointerAcrossAddressesTenBitOrTheGeneralCall) {
  uint8_t b[1] = {0x06}, r[1] = {};
  contego_i2c_tx tx[2];
  contego_i2c_msg other[2] = {{0x40, 0, 1, b}, {0x41, I2C_M_RD, 1, r}};
  ASSERT_EQ(contego_i2c_transactions(other, 2, tx), 2u);
  EXPECT_EQ(tx[0].kind, CONTEGO_TX_WRITE);
  EXPECT_EQ(tx[1].kind, CONTEGO_TX_READ);
  EXPECT_EQ(tx[1].len, 0u);
  contego_i2c_msg ten[2] = {{0x40, 0, 1, b}, {0x40, I2C_M_RD | I2C_M_TEN, 1, r}};
  ASSERT_EQ(contego_i2c_transactions(ten, 2, tx), 2u);
  EXPECT_EQ(tx[1].ten, 1);
  contego_i2c_msg general[2] = {{0x00, 0, 1, b}, {0x00, I2C_M_RD, 1, r}};
  ASSERT_EQ(contego_i2c_transactions(general, 2, tx), 2u);
  EXPECT_EQ(tx[0].kind, CONTEGO_TX_WRITE);
}

TEST(I2cTransactions, ALongerWriteBeforeAReadIsAWriteOfItsOwn) {
  uint8_t w[2] = {0x06, 1}, r[1] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 2, w}, {0x40, I2C_M_RD, 1, r}};
  contego_i2c_tx tx[2];
  ASSERT_EQ(contego_i2c_transactions(m, 2, tx), 2u);
  EXPECT_EQ(tx[0].kind, CONTEGO_TX_WRITE);
  EXPECT_EQ(tx[1].kind, CONTEGO_TX_READ);
  EXPECT_EQ(contego_i2c_transactions(m, 0, tx), 0u);
}

TEST(I2cTransactions, AWriteAndTheReadAnsweringItAreOneCombinedTransfer) {
  uint8_t w[3] = {0x10, 0x34, 0x12}, reg[1] = {0x06}, r[2] = {};
  contego_i2c_tx tx[3];
  // A process call: the write, then the answer without a pointer.
  contego_i2c_msg proc[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD, 2, r}};
  ASSERT_EQ(contego_i2c_transactions(proc, 2, tx), 2u);
  EXPECT_TRUE(contego_i2c_write_then_read(&tx[0], &tx[1]));
  EXPECT_FALSE(contego_i2c_write_then_read(&tx[1], &tx[0]));
  // A read with its own pointer answers no write before it.
  contego_i2c_msg pointer[3] = {{0x40, 0, 3, w}, {0x40, 0, 1, reg}, {0x40, I2C_M_RD, 2, r}};
  ASSERT_EQ(contego_i2c_transactions(pointer, 3, tx), 2u);
  EXPECT_FALSE(contego_i2c_write_then_read(&tx[0], &tx[1]));
  // Another address, ten-bit against seven, the general call: separate.
  contego_i2c_msg other[2] = {{0x40, 0, 3, w}, {0x41, I2C_M_RD, 2, r}};
  ASSERT_EQ(contego_i2c_transactions(other, 2, tx), 2u);
  EXPECT_FALSE(contego_i2c_write_then_read(&tx[0], &tx[1]));
  contego_i2c_msg ten[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD | I2C_M_TEN, 2, r}};
  ASSERT_EQ(contego_i2c_transactions(ten, 2, tx), 2u);
  EXPECT_FALSE(contego_i2c_write_then_read(&tx[0], &tx[1]));
  contego_i2c_msg general[2] = {{0x00, 0, 3, w}, {0x00, I2C_M_RD, 2, r}};
  ASSERT_EQ(contego_i2c_transactions(general, 2, tx), 2u);
  EXPECT_FALSE(contego_i2c_write_then_read(&tx[0], &tx[1]));
}

contego_verdict emits(uint16_t addr, std::initializer_list<std::initializer_list<uint8_t>> writes) {
  contego_verdict v{};
  v.addr = addr;
  for (const auto& w : writes) {
    v.emit_len[v.emit_count++] = static_cast<uint16_t>(w.size());
    for (const uint8_t b : w) v.emit_bytes[v.emit_bytes_used++] = b;
  }
  return v;
}

TEST(I2cTransactions, AWriteGoesOutAsSentWhenItsEmitsAreItsBytes) {
  const uint8_t led[5] = {0x1A, 0x00, 0x00, 0x41, 0x02};  // LED5: on 0, off 577
  auto as_sent = [&](const contego_verdict& v, uint32_t len = 5) {
    return contego_i2c_emits_as_sent(&v, 0x40, led, len) != 0;
  };
  EXPECT_TRUE(as_sent(emits(0x40, {{0x1A, 0x00, 0x00, 0x41, 0x02}})));  // one command: exact
  // Checked register by register (auto-increment): the same bytes on the wire.
  EXPECT_TRUE(as_sent(emits(0x40, {{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0x41}, {0x1D, 0x02}})));
  EXPECT_TRUE(as_sent(emits(0x40, {{0x1A, 0x00, 0x00}, {0x1C, 0x41, 0x02}})));
  // Anything else is not what was sent.
  EXPECT_FALSE(as_sent(emits(0x40, {{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0x41}})));  // one short
  EXPECT_FALSE(as_sent(emits(0x40, {{0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0xA4}, {0x1D, 0x01}})));
  EXPECT_FALSE(as_sent(emits(0x40, {{0x1A, 0x00}, {0x1A, 0x00}, {0x1C, 0x41}, {0x1D, 0x02}})));
  EXPECT_FALSE(as_sent(emits(0x40, {{0x1A, 0x00, 0x00, 0x41, 0x02}, {0x1A}})));
  EXPECT_FALSE(as_sent(emits(0x41, {{0x1A, 0x00, 0x00, 0x41, 0x02}})));  // another address
  EXPECT_FALSE(as_sent(emits(0x40, {})));                                // nothing written
  EXPECT_FALSE(as_sent(emits(0x40, {{0x1A, 0x00, 0x00, 0x41, 0x02}}), 4));
  const uint8_t reg[1] = {0x1A};
  const contego_verdict pointer = emits(0x40, {{0x1A}});
  EXPECT_TRUE(contego_i2c_emits_as_sent(&pointer, 0x40, reg, 1));
}

}  // namespace
