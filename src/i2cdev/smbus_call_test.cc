// The SMBus call table through its C ABI, as contego.ko and the user-space
// decoder call it.
#include <gtest/gtest.h>
#include <linux/i2c.h>
#include <vector>

#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

namespace {

struct Call {
  contego_i2c_msg m[2];
  uint8_t wire[CONTEGO_SMBUS_WIRE_BYTES] = {};
  uint8_t rbuf[CONTEGO_SMBUS_DATA_BYTES - 1] = {};
  int n = 0;
  Call(uint8_t read, uint32_t size, std::vector<uint8_t> data, uint8_t command = 0x10,
       uint16_t flags = 0) {
    uint8_t bytes[CONTEGO_SMBUS_DATA_BYTES] = {};
    for (size_t i = 0; i < data.size(); ++i) bytes[i] = data[i];
    n = contego_i2c_smbus_msgs(0x40, flags, read, command, size, bytes, m, wire, rbuf);
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

// SMBus PEC computed here the slow way: CRC-8, polynomial 0x07, initial 0.
uint8_t reference_pec(const std::vector<uint8_t>& bytes) {
  uint8_t crc = 0;
  for (uint8_t b : bytes) {
    for (int bit = 7; bit >= 0; --bit) {
      const bool top = ((crc >> 7) ^ (b >> bit)) & 1;
      crc = static_cast<uint8_t>((crc << 1) ^ (top ? 0x07 : 0));
    }
  }
  return crc;
}

TEST(I2cSmbusCall, AWriteWithPecOnTheWireEndsWithItsPacketErrorCode) {
  const std::vector<uint8_t> check{'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  ASSERT_EQ(reference_pec(check), 0xF4);  // CRC-8/SMBUS's check value
  constexpr uint16_t kPec = CONTEGO_I2C_CLIENT_PEC;
  // 0x40 writing: address byte 0x80, then the message.
  Call byte_data(0, CONTEGO_SMBUS_BYTE_DATA, {0x55}, 0x10, kPec);
  ASSERT_EQ(byte_data.n, 1);
  EXPECT_EQ(byte_data.written(0),
            std::vector<uint8_t>({0x10, 0x55, reference_pec({0x80, 0x10, 0x55})}));
  EXPECT_EQ(byte_data.m[0].flags, 0);  // PEC is no message flag
  Call send(0, CONTEGO_SMBUS_BYTE, {}, 0x1F, kPec);
  EXPECT_EQ(send.written(0), std::vector<uint8_t>({0x1F, reference_pec({0x80, 0x1F})}));
  Call word(0, CONTEGO_SMBUS_WORD_DATA, {0x34, 0x12}, 0x10, kPec);
  EXPECT_EQ(word.written(0),
            std::vector<uint8_t>({0x10, 0x34, 0x12, reference_pec({0x80, 0x10, 0x34, 0x12})}));
  std::vector<uint8_t> full(33, 0xA5);
  full[0] = 32;
  Call block(0, CONTEGO_SMBUS_BLOCK_DATA, full, 0x10, kPec);
  ASSERT_EQ(block.m[0].len, CONTEGO_SMBUS_WIRE_BYTES);  // command, count, 32 bytes, PEC
  std::vector<uint8_t> sent{0x80, 0x10};
  sent.insert(sent.end(), full.begin(), full.end());
  EXPECT_EQ(block.wire[34], reference_pec(sent));
  // No PEC: an I2C block write (i2c-core adds none), a quick command.
  EXPECT_EQ(Call(0, CONTEGO_SMBUS_I2C_BLOCK_DATA, {1, 7}, 0x10, kPec).written(0),
            std::vector<uint8_t>({0x10, 7}));
  EXPECT_EQ(Call(0, CONTEGO_SMBUS_QUICK, {}, 0x10, kPec).m[0].len, 0);
}

TEST(I2cSmbusCall, AReadWithPecOnTheWireTakesTheDevicesPecAsOneMoreByte) {
  constexpr uint16_t kPec = CONTEGO_I2C_CLIENT_PEC;
  Call read(1, CONTEGO_SMBUS_BYTE_DATA, {}, 0x10, kPec);
  ASSERT_EQ(read.n, 2);
  EXPECT_EQ(read.written(0), std::vector<uint8_t>({0x10}));  // the request has none
  EXPECT_EQ(read.m[1].len, 2);
  // What the answer's PEC continues: 0x40 writing, the pointer, 0x40 reading.
  EXPECT_EQ(contego_i2c_answer_pec(read.m, 2), reference_pec({0x80, 0x10, 0x81}));
  EXPECT_EQ(Call(1, CONTEGO_SMBUS_WORD_DATA, {}, 0x10, kPec).m[1].len, 3);
  Call receive(1, CONTEGO_SMBUS_BYTE, {}, 0x10, kPec);
  EXPECT_EQ(receive.m[0].len, 2);
  EXPECT_EQ(contego_i2c_answer_pec(receive.m, 1), reference_pec({0x81}));
  Call proc(0, CONTEGO_SMBUS_PROC_CALL, {0x34, 0x12}, 0x10, kPec);
  EXPECT_EQ(proc.written(0), std::vector<uint8_t>({0x10, 0x34, 0x12}));  // no PEC of its own
  EXPECT_EQ(proc.m[1].len, 3);
  EXPECT_EQ(contego_i2c_answer_pec(proc.m, 2), reference_pec({0x80, 0x10, 0x34, 0x12, 0x81}));
  // The counted reads go without: their answer one byte longer has no form.
  EXPECT_EQ(Call(1, CONTEGO_SMBUS_BLOCK_DATA, {}, 0x10, kPec).m[1].len, 33);
  Call block_proc(0, CONTEGO_SMBUS_BLOCK_PROC_CALL, {1, 9}, 0x10, kPec);
  EXPECT_EQ(block_proc.written(0), std::vector<uint8_t>({0x10, 1, 9}));
  EXPECT_EQ(block_proc.m[1].len, 33);
  EXPECT_EQ(Call(1, CONTEGO_SMBUS_I2C_BLOCK_DATA, {4}, 0x10, kPec).m[1].len, 4);
  // The PEC itself, on from a partial one as i2c-core checks an answer.
  const std::vector<uint8_t> all{0x80, 0x10, 0x81, 0x61};
  const uint8_t first[] = {0x80, 0x10};
  const uint8_t rest[] = {0x81, 0x61};
  EXPECT_EQ(contego_smbus_pec(contego_smbus_pec(0, first, 2), rest, 2), reference_pec(all));
  // A ten-bit address: its low eight bits, shifted, as i2c-core takes them.
  Call ten(0, CONTEGO_SMBUS_BYTE_DATA, {0x55}, 0x10, kPec | CONTEGO_I2C_M_TEN);
  EXPECT_EQ(ten.m[0].flags, CONTEGO_I2C_M_TEN);
  EXPECT_EQ(ten.wire[2], reference_pec({0x80, 0x10, 0x55}));
}

TEST(I2cSmbusCall, PecIsOnTheWireOnlyWhereTheAdapterPutsItThere) {
  EXPECT_TRUE(contego_i2c_pec_on_wire(1, I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL));
  EXPECT_TRUE(contego_i2c_pec_on_wire(1, I2C_FUNC_SMBUS_BYTE_DATA | I2C_FUNC_SMBUS_PEC));
  EXPECT_FALSE(contego_i2c_pec_on_wire(1, I2C_FUNC_SMBUS_BYTE_DATA));  // i2c-stub's kind
  EXPECT_FALSE(contego_i2c_pec_on_wire(0, I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL));
  EXPECT_EQ(CONTEGO_I2C_CLIENT_PEC, 0x04u);  // the kernel's I2C_CLIENT_PEC (not in the UAPI)
  EXPECT_EQ(CONTEGO_I2C_FUNC_SMBUS_PEC, static_cast<unsigned>(I2C_FUNC_SMBUS_PEC));
}

}  // namespace
