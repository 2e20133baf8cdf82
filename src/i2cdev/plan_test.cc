// The shared planner through its C ABI, as contego.ko calls it (the C++
// wrapper's exhaustive tests are src/bus/smbus_plan_test.cc).
#include <cstddef>
#include <cstring>
#include <gtest/gtest.h>
#include <linux/i2c.h>

#include "contego/i2c_plan.h"

namespace {

// contego.ko passes its struct i2c_msg array as contego_i2c_msg.
static_assert(sizeof(contego_i2c_msg) == sizeof(i2c_msg));
static_assert(offsetof(contego_i2c_msg, addr) == offsetof(i2c_msg, addr));
static_assert(offsetof(contego_i2c_msg, flags) == offsetof(i2c_msg, flags));
static_assert(offsetof(contego_i2c_msg, len) == offsetof(i2c_msg, len));
static_assert(offsetof(contego_i2c_msg, buf) == offsetof(i2c_msg, buf));
static_assert(CONTEGO_SMBUS_QUICK == I2C_SMBUS_QUICK && CONTEGO_SMBUS_BYTE == I2C_SMBUS_BYTE &&
              CONTEGO_SMBUS_BYTE_DATA == I2C_SMBUS_BYTE_DATA &&
              CONTEGO_SMBUS_WORD_DATA == I2C_SMBUS_WORD_DATA &&
              CONTEGO_SMBUS_PROC_CALL == I2C_SMBUS_PROC_CALL &&
              CONTEGO_SMBUS_BLOCK_DATA == I2C_SMBUS_BLOCK_DATA &&
              CONTEGO_SMBUS_BLOCK_PROC_CALL == I2C_SMBUS_BLOCK_PROC_CALL &&
              CONTEGO_SMBUS_I2C_BLOCK_DATA == I2C_SMBUS_I2C_BLOCK_DATA);
static_assert(CONTEGO_SMBUS_DATA_BYTES == sizeof(i2c_smbus_data));

// i2c-stub's functionality: SMBus only, no block or process calls.
constexpr uint64_t kStub = I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE | I2C_FUNC_SMBUS_BYTE_DATA |
                           I2C_FUNC_SMBUS_WORD_DATA | I2C_FUNC_SMBUS_I2C_BLOCK;

contego_i2c_plan plan(contego_i2c_msg* m, uint32_t n, uint64_t funcs) {
  contego_i2c_plan p;
  std::memset(&p, 0xA5, sizeof p);  // every field is set by the planner
  contego_i2c_plan_transfer(m, n, funcs, &p);
  return p;
}

TEST(I2cPlan, PlainI2cSendsTheMessagesAsTheyAre) {
  uint8_t w[3] = {0x06, 0x01, 0x02}, r[2] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD, 2, r}};
  const contego_i2c_plan p = plan(m, 2, I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL);
  EXPECT_EQ(p.form, CONTEGO_I2C_FORM_I2C);
  EXPECT_EQ(p.refusal, CONTEGO_I2C_NOT_REFUSED);
}

TEST(I2cPlan, ARegisterWriteIsWriteByteDataOnAnSmbusAdapter) {
  uint8_t w[2] = {0x06, 0x99};
  contego_i2c_msg m[1] = {{0x40, 0, 2, w}};
  const contego_i2c_plan p = plan(m, 1, kStub);
  ASSERT_EQ(p.form, CONTEGO_I2C_FORM_SMBUS);
  EXPECT_EQ(p.op.size, CONTEGO_SMBUS_BYTE_DATA);
  EXPECT_EQ(p.op.addr, 0x40);
  EXPECT_EQ(p.op.read, 0);
  EXPECT_EQ(p.op.command, 0x06);
  EXPECT_EQ(p.op.data[0], 0x99);
  EXPECT_EQ(p.op.reply, -1);
}

TEST(I2cPlan, ACombinedReadOfFourIsAnI2cBlockRead) {
  uint8_t w[1] = {0x06}, r[4] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 1, w}, {0x40, I2C_M_RD, 4, r}};
  const contego_i2c_plan p = plan(m, 2, kStub);
  ASSERT_EQ(p.form, CONTEGO_I2C_FORM_SMBUS);
  EXPECT_EQ(p.op.size, CONTEGO_SMBUS_I2C_BLOCK_DATA);
  EXPECT_EQ(p.op.read, 1);
  EXPECT_EQ(p.op.data[0], 4);
  EXPECT_EQ(p.op.reply, 1);
}

TEST(I2cPlan, AMissingFormIsRefusedNamingWhatTheAdapterLacks) {
  uint8_t w[1] = {0x06}, r[33] = {1};
  contego_i2c_msg m[2] = {{0x40, 0, 1, w}, {0x40, I2C_M_RD | I2C_M_RECV_LEN, 33, r}};
  const contego_i2c_plan p = plan(m, 2, kStub);
  ASSERT_EQ(p.form, CONTEGO_I2C_FORM_REFUSED);
  EXPECT_EQ(p.refusal, CONTEGO_I2C_NO_FORM);
  ASSERT_EQ(p.candidate_count, 1);
  EXPECT_STREQ(contego_smbus_name(p.candidates[0], p.candidates_read), "SMBus block read");
}

TEST(I2cPlan, ProcessCallsHaveTheirForms) {
  uint8_t w[3] = {0x10, 0x34, 0x12}, r[2] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 3, w}, {0x40, I2C_M_RD, 2, r}};
  contego_i2c_plan p = plan(m, 2, kStub | I2C_FUNC_SMBUS_PROC_CALL);
  ASSERT_EQ(p.form, CONTEGO_I2C_FORM_SMBUS);
  EXPECT_EQ(p.op.size, CONTEGO_SMBUS_PROC_CALL);
  EXPECT_EQ(p.op.data[0], 0x34);
  EXPECT_EQ(p.op.data[1], 0x12);
  p = plan(m, 2, kStub);
  EXPECT_EQ(p.refusal, CONTEGO_I2C_NO_FORM);
}

TEST(I2cPlan, ShapesWithoutAnSmbusFormAreRefusedWithTheirReason) {
  uint8_t w[40] = {0x06}, r[4] = {};
  contego_i2c_msg too_long[1] = {{0x40, 0, 40, w}};
  EXPECT_EQ(plan(too_long, 1, kStub).refusal, CONTEGO_I2C_WRITE_TOO_LONG);
  contego_i2c_msg ten[1] = {{0x140, I2C_M_TEN, 2, w}};
  EXPECT_EQ(plan(ten, 1, kStub).refusal, CONTEGO_I2C_TEN_BIT);
  contego_i2c_msg lone[1] = {{0x40, I2C_M_RD, 4, r}};
  EXPECT_EQ(plan(lone, 1, kStub).refusal, CONTEGO_I2C_LONG_READ_ALONE);
  contego_i2c_msg three[3] = {{0x40, 0, 1, w}, {0x40, 0, 1, w}, {0x40, I2C_M_RD, 1, r}};
  EXPECT_EQ(plan(three, 3, kStub).refusal, CONTEGO_I2C_SHAPE);
  EXPECT_EQ(plan(three, 0, kStub).refusal, CONTEGO_I2C_NO_MESSAGES);
  contego_i2c_msg zero[1] = {{0x40, 0, 0, nullptr}};
  EXPECT_EQ(plan(zero, 1, I2C_FUNC_I2C).refusal, CONTEGO_I2C_NO_ZERO_LENGTH);
  for (uint32_t why = CONTEGO_I2C_NO_MESSAGES; why <= CONTEGO_I2C_SHAPE; ++why) {
    EXPECT_GT(std::strlen(contego_i2c_refusal_text(why)), 10u) << why;
  }
}

TEST(I2cPlan, RepliesLandInTheReadMessage) {
  uint8_t w[1] = {0x06}, r[33] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 1, w}, {0x40, I2C_M_RD | I2C_M_RECV_LEN, 33, r}};
  contego_smbus_op op{};
  op.size = CONTEGO_SMBUS_BLOCK_DATA;
  op.reply = 1;
  uint8_t data[CONTEGO_SMBUS_DATA_BYTES] = {3, 0xA, 0xB, 0xC};
  ASSERT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 0);
  EXPECT_EQ(m[1].len, 4);
  EXPECT_EQ(r[0], 3);
  EXPECT_EQ(r[3], 0xC);
  data[0] = 0;  // a block count of 0 is a protocol error
  EXPECT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 71);
  op.reply = 2;
  EXPECT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 22);
  op.reply = -1;
  EXPECT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 0);
}

TEST(I2cPlan, AnI2cBlockReadReturningMoreThanAskedIsAProtocolError) {
  uint8_t r[4] = {};
  contego_i2c_msg m[2] = {{0x40, 0, 0, nullptr}, {0x40, I2C_M_RD, 4, r}};
  contego_smbus_op op{};
  op.size = CONTEGO_SMBUS_I2C_BLOCK_DATA;
  op.reply = 1;
  op.data[0] = 2;
  uint8_t data[CONTEGO_SMBUS_DATA_BYTES] = {3, 1, 2, 3};
  EXPECT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 71);
  data[0] = 2;
  EXPECT_EQ(contego_i2c_deliver_reply(&op, data, m, 2), 0);
  EXPECT_EQ(m[1].len, 2);
  EXPECT_EQ(r[1], 2);
}

}  // namespace
