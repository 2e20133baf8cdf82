// The SMBus call table through its C ABI, as contego.ko and the user-space
// decoder call it.
#include <gtest/gtest.h>
#include <linux/i2c.h>
#include <vector>

#include "contego/i2c_plan.h"

namespace {

struct Call {
  contego_i2c_msg m[2];
  uint8_t wire[CONTEGO_SMBUS_WIRE_BYTES] = {};
  uint8_t rbuf[CONTEGO_SMBUS_DATA_BYTES - 1] = {};
  int n = 0;
  Call(uint8_t read, uint32_t size, std::vector<uint8_t> data, uint8_t command = 0x10,
       uint16_t ten = 0) {
    uint8_t bytes[CONTEGO_SMBUS_DATA_BYTES] = {};
    for (size_t i = 0; i < data.size(); ++i) bytes[i] = data[i];
    n = contego_i2c_smbus_msgs(0x40, ten, read, command, size, bytes, m, wire, rbuf);
  }
  std::vector<uint8_t> written(int i) const { return {m[i].buf, m[i].buf + m[i].len}; }
};

TEST(I2cSmbusCall, WritesAreTheCommandByteAndTheData) {
  Call byte(0, CONTEGO_SMBUS_BYTE, {});
  ASSERT_EQ(byte.n, 1);
  EXPECT_EQ(byte.written(0), std::vector<uint8_t>({0x10}));
  Call word(0, CONTEGO_SMBUS_WORD_DATA, {0x34, 0x12});
  ASSERT_EQ(word.n, 1);
  EXPECT_EQ(word.written(0), std::vector<uint8_t>({0x10, 0x34, 0x12}));
  Call block(0, CONTEGO_SMBUS_BLOCK_DATA, {2, 7, 8});
  EXPECT_EQ(block.written(0), std::vector<uint8_t>({0x10, 2, 7, 8}));  // the count is sent
  Call i2c(0, CONTEGO_SMBUS_I2C_BLOCK_DATA, {2, 7, 8});
  EXPECT_EQ(i2c.written(0), std::vector<uint8_t>({0x10, 7, 8}));  // the length is not
  EXPECT_EQ(i2c.m[0].flags, 0);
}

TEST(I2cSmbusCall, ReadsAreARegisterPointerAndARead) {
  Call byte_data(1, CONTEGO_SMBUS_BYTE_DATA, {});
  ASSERT_EQ(byte_data.n, 2);
  EXPECT_EQ(byte_data.written(0), std::vector<uint8_t>({0x10}));
  EXPECT_EQ(byte_data.m[1].flags, I2C_M_RD);
  EXPECT_EQ(byte_data.m[1].len, 1);
  Call block(1, CONTEGO_SMBUS_BLOCK_DATA, {});
  ASSERT_EQ(block.n, 2);
  EXPECT_EQ(block.m[1].flags, I2C_M_RD | I2C_M_RECV_LEN);
  EXPECT_EQ(block.m[1].len, 33);
  EXPECT_EQ(block.rbuf[0], 1);  // RECV_LEN's preset
  Call i2c(1, CONTEGO_SMBUS_I2C_BLOCK_DATA, {5});
  EXPECT_EQ(i2c.m[1].len, 5);
  Call receive(1, CONTEGO_SMBUS_BYTE, {});
  ASSERT_EQ(receive.n, 1);
  EXPECT_EQ(receive.m[0].flags, I2C_M_RD);
}

TEST(I2cSmbusCall, ProcessCallsWriteThenReadWithoutPointer) {
  Call proc(0, CONTEGO_SMBUS_PROC_CALL, {0x78, 0x56});
  ASSERT_EQ(proc.n, 2);
  EXPECT_EQ(proc.written(0), std::vector<uint8_t>({0x10, 0x78, 0x56}));
  EXPECT_EQ(proc.m[1].len, 2);
  Call block(1, CONTEGO_SMBUS_BLOCK_PROC_CALL, {1, 9});  // read_write does not matter
  ASSERT_EQ(block.n, 2);
  EXPECT_EQ(block.written(0), std::vector<uint8_t>({0x10, 1, 9}));
  EXPECT_EQ(block.m[1].flags, I2C_M_RD | I2C_M_RECV_LEN);
}

TEST(I2cSmbusCall, QuickAndTenBitAndBadCalls) {
  Call quick(1, CONTEGO_SMBUS_QUICK, {});
  ASSERT_EQ(quick.n, 1);
  EXPECT_EQ(quick.m[0].len, 0);
  EXPECT_EQ(quick.m[0].flags, I2C_M_RD);
  Call ten(0, CONTEGO_SMBUS_BYTE_DATA, {1}, 0x10, I2C_M_TEN);
  EXPECT_EQ(ten.m[0].flags, I2C_M_TEN);
  EXPECT_EQ(Call(0, CONTEGO_SMBUS_BLOCK_DATA, {33}).n, -22);
  EXPECT_EQ(Call(1, CONTEGO_SMBUS_I2C_BLOCK_DATA, {33}).n, -22);
  EXPECT_EQ(Call(0, 6, {}).n, -22);  // BROKEN is the caller's to rewrite
  EXPECT_EQ(Call(0, 9, {}).n, -22);
  EXPECT_EQ(Call(0, CONTEGO_SMBUS_BLOCK_DATA, {0}).written(0), std::vector<uint8_t>({0x10, 0}));
}

}  // namespace
