// Decoding is tested with the kernel's own UAPI structs in this process's
// memory, so a layout mistake in the decoder shows up as a wrong transfer.
#include "intercept/i2c_abi/i2c_abi.h"

#include <errno.h>

#include <climits>
#include <cstring>
#include <gtest/gtest.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>

#include "contego/i2c_plan.h"

namespace contego::intercept::i2c_abi {
namespace {

uint64_t addr_of(const void* p) { return reinterpret_cast<uint64_t>(p); }

class I2cAbi : public ::testing::Test {
 protected:
  FdState state;
  LocalMemory mem;

  Decoded smbus(uint8_t rw, uint8_t cmd, uint32_t size, i2c_smbus_data* data,
                uint64_t funcs = 0x0FFF0001) {
    i2c_smbus_ioctl_data a{};
    a.read_write = rw;
    a.command = cmd;
    a.size = size;
    a.data = data;
    return decode_ioctl(state, I2C_SMBUS, addr_of(&a), mem, funcs);
  }
};

TEST_F(I2cAbi, RequestNumbersMatchTheKernelHeaders) {
  EXPECT_EQ(kI2cSlave, static_cast<unsigned long>(I2C_SLAVE));
  EXPECT_EQ(kI2cSlaveForce, static_cast<unsigned long>(I2C_SLAVE_FORCE));
  EXPECT_EQ(kI2cRdwr, static_cast<unsigned long>(I2C_RDWR));
  EXPECT_EQ(kI2cSmbus, static_cast<unsigned long>(I2C_SMBUS));
  EXPECT_EQ(kI2cFuncs, static_cast<unsigned long>(I2C_FUNCS));
  EXPECT_EQ(kI2cPec, static_cast<unsigned long>(I2C_PEC));
  EXPECT_EQ(kSmbusI2cBlockBroken, static_cast<uint32_t>(I2C_SMBUS_I2C_BLOCK_BROKEN));
}

TEST_F(I2cAbi, SlaveAddressRangeFollowsTenbit) {
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE, 0x80, mem, 0).err, EINVAL);
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE, 0x40, mem, 0).err, 0);
  EXPECT_EQ(state.addr, 0x40);
  EXPECT_EQ(decode_ioctl(state, I2C_TENBIT, 1, mem, 0).err, 0);
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE_FORCE, 0x3FF, mem, 0).err, 0);
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE_FORCE, 0x400, mem, 0).err, EINVAL);
  EXPECT_EQ(state.addr, 0x3FF);
}

TEST_F(I2cAbi, SlaveIsBusyWhereAKernelDriverOwnsTheAddressButForceIsNot) {
  auto busy = [](uint8_t, uint16_t addr) { return addr == 0x40; };
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE, 0x40, mem, 0, busy).err, EBUSY);
  EXPECT_EQ(decode_ioctl(state, I2C_SLAVE_FORCE, 0x40, mem, 0, busy).err, 0);
}

TEST_F(I2cAbi, UnknownRequestIsEnotty) {
  EXPECT_EQ(decode_ioctl(state, 0x5401 /* TCGETS */, 0, mem, 0).err, ENOTTY);
}

TEST_F(I2cAbi, FuncsWritesAnUnsignedLong) {
  unsigned long funcs = 0;
  EXPECT_EQ(decode_ioctl(state, I2C_FUNCS, addr_of(&funcs), mem, 0x0FFF0001).err, 0);
  EXPECT_EQ(funcs, 0x0FFF0001ul);
  EXPECT_EQ(decode_ioctl(state, I2C_FUNCS, 0, mem, 1).err, EFAULT);
}

// The answer is the adapter's own mask as the trusted side reports it, never
// a fixed one: on an SMBus-only adapter (i2c-stub: quick, byte, byte data,
// word data, I2C block) a program must see no I2C_FUNC_I2C, as on the node.
TEST_F(I2cAbi, FuncsIsTheAdaptersMaskUnchanged) {
  constexpr unsigned long kStub = I2C_FUNC_SMBUS_QUICK | I2C_FUNC_SMBUS_BYTE |
                                  I2C_FUNC_SMBUS_BYTE_DATA | I2C_FUNC_SMBUS_WORD_DATA |
                                  I2C_FUNC_SMBUS_I2C_BLOCK;
  static_assert(kStub == 0x0C7F0000ul);
  for (unsigned long mask : {kStub, 0x0ul, static_cast<unsigned long>(I2C_FUNC_I2C),
                             static_cast<unsigned long>(I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL)}) {
    unsigned long funcs = ~0ul;
    EXPECT_EQ(decode_ioctl(state, I2C_FUNCS, addr_of(&funcs), mem, mask).err, 0);
    EXPECT_EQ(funcs, mask);
  }
}

TEST_F(I2cAbi, RetriesAndTimeoutAboveIntMaxAreEinval) {
  EXPECT_EQ(decode_ioctl(state, I2C_RETRIES, 0x80000000ul, mem, 0).err, EINVAL);
  EXPECT_EQ(decode_ioctl(state, I2C_TIMEOUT, 0x80000000ul, mem, 0).err, EINVAL);
  EXPECT_EQ(decode_ioctl(state, I2C_TIMEOUT, 10, mem, 0).err, 0);
}

// Tens of milliseconds, so arg * 10 must fit an int, as contego.ko checks.
TEST_F(I2cAbi, TimeoutWhoseMillisecondsWouldWrapIsEinval) {
  EXPECT_EQ(decode_ioctl(state, I2C_TIMEOUT, INT_MAX / 10 + 1ul, mem, 0).err, EINVAL);
  EXPECT_EQ(decode_ioctl(state, I2C_TIMEOUT, INT_MAX / 10, mem, 0).err, 0);
  EXPECT_EQ(state.timeout_10ms, static_cast<uint32_t>(INT_MAX / 10));
}

// The descriptor's own I2C_RETRIES/I2C_TIMEOUT go with every transfer once
// it set either (the monitor applies them per call); before, none do.
TEST_F(I2cAbi, EveryTransferCarriesTheDescriptorsOwnRetriesAndTimeout) {
  state.addr = 0x40;
  uint8_t byte = 0x06;
  EXPECT_FALSE(decode_write(state, addr_of(&byte), 1, mem).transfer.timing.own);
  EXPECT_EQ(decode_ioctl(state, I2C_RETRIES, 0x80000000ul, mem, 0).err, EINVAL);
  EXPECT_FALSE(state.own_timing);  // a refused value sets nothing
  EXPECT_EQ(decode_ioctl(state, I2C_RETRIES, 3, mem, 0).err, 0);
  const gate::Timing only_retries = decode_read(state, addr_of(&byte), 1).transfer.timing;
  EXPECT_TRUE(only_retries.own);
  EXPECT_EQ(only_retries.retries, 3u);
  EXPECT_EQ(only_retries.timeout_10ms, 100u);  // i2c-core's default: 1 s
  EXPECT_EQ(decode_ioctl(state, I2C_TIMEOUT, 7, mem, 0).err, 0);
  i2c_smbus_data data{};
  for (const Decoded& d : {decode_write(state, addr_of(&byte), 1, mem),
                           smbus(I2C_SMBUS_WRITE, 0x06, I2C_SMBUS_BYTE_DATA, &data),
                           smbus(I2C_SMBUS_WRITE, 0, I2C_SMBUS_QUICK, nullptr)}) {
    ASSERT_EQ(d.action, Decoded::Action::kTransfer);
    EXPECT_TRUE(d.transfer.timing.own);
    EXPECT_EQ(d.transfer.timing.retries, 3u);
    EXPECT_EQ(d.transfer.timing.timeout_10ms, 7u);
  }
  i2c_msg m{0x40, 0, 1, &byte};
  i2c_rdwr_ioctl_data rdwr{&m, 1};
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&rdwr), mem, 0).transfer.timing.retries, 3u);
  FdState fresh;  // another open(): none
  EXPECT_FALSE(decode_read(fresh, addr_of(&byte), 1).transfer.timing.own);
}

TEST_F(I2cAbi, SmbusByteDataWriteIsCommandThenByte) {
  state.addr = 0x40;
  i2c_smbus_data data{};
  data.byte = 0x21;
  Decoded d = smbus(I2C_SMBUS_WRITE, 0x00, I2C_SMBUS_BYTE_DATA, &data);
  ASSERT_EQ(d.action, Decoded::Action::kTransfer);
  ASSERT_EQ(d.transfer.messages.size(), 1u);
  EXPECT_EQ(d.transfer.messages[0].addr, 0x40);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0x00, 0x21}));
}

TEST_F(I2cAbi, APecWriteCarriesItsPacketErrorCodeWhereTheAdapterSendsOne) {
  state.addr = 0x40;
  ASSERT_EQ(decode_ioctl(state, I2C_PEC, 1, mem, 0).err, 0);
  i2c_smbus_data data{};
  data.byte = 0x34;
  // A plain adapter (i2c-core's SMBus emulation adds the PEC): the core is
  // given the byte the chip will get, CRC-8 of 0x80, 0x10, 0x34.
  const uint64_t plain = I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL;
  EXPECT_EQ(
      smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_BYTE_DATA, &data, plain).transfer.messages[0].data,
      (std::vector<uint8_t>{0x10, 0x34, 0xD0}));
  // An adapter without I2C_FUNC_SMBUS_PEC sends none.
  EXPECT_EQ(smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_BYTE_DATA, &data).transfer.messages[0].data,
            (std::vector<uint8_t>{0x10, 0x34}));
  // write() never carries one, as under i2c-dev.
  const uint8_t bytes[] = {0x10, 0x34};
  EXPECT_EQ(decode_write(state, addr_of(bytes), 2, mem).transfer.messages[0].data,
            (std::vector<uint8_t>{0x10, 0x34}));
  ASSERT_EQ(decode_ioctl(state, I2C_PEC, 0, mem, 0).err, 0);
  EXPECT_EQ(
      smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_BYTE_DATA, &data, plain).transfer.messages[0].data,
      (std::vector<uint8_t>{0x10, 0x34}));
}

TEST_F(I2cAbi, APecReadIsAnsweredOnlyWhenTheDevicesPecMatches) {
  state.addr = 0x40;
  ASSERT_EQ(decode_ioctl(state, I2C_PEC, 1, mem, 0).err, 0);
  i2c_smbus_data data{};
  Decoded d =
      smbus(I2C_SMBUS_READ, 0x10, I2C_SMBUS_BYTE_DATA, &data, I2C_FUNC_I2C | I2C_FUNC_SMBUS_EMUL);
  ASSERT_EQ(d.transfer.messages.size(), 2u);
  EXPECT_EQ(d.transfer.messages[1].len, 2);  // the byte and the device's PEC
  // i2c-core's PEC of 0x80, 0x10, 0x81 (0x40 reading), 0x61.
  const uint8_t answer[] = {0x80, 0x10, 0x81, 0x61};
  const uint8_t good = contego_smbus_pec(0, answer, sizeof answer);
  gate::TransferReply reply;
  reply.reads = {{0x61, good}};
  EXPECT_EQ(complete(d.completion, reply, mem), 0);
  EXPECT_EQ(data.byte, 0x61);
  data.byte = 0;
  reply.reads = {{0x61, static_cast<uint8_t>(good ^ 1)}};
  EXPECT_EQ(complete(d.completion, reply, mem), -EBADMSG);  // as i2c-core's check
  EXPECT_EQ(data.byte, 0);
  // Without the adapter's PEC, the answer is the byte alone.
  Decoded plain = smbus(I2C_SMBUS_READ, 0x10, I2C_SMBUS_BYTE_DATA, &data);
  EXPECT_EQ(plain.transfer.messages[1].len, 1);
  reply.reads = {{0x62}};
  EXPECT_EQ(complete(plain.completion, reply, mem), 0);
  EXPECT_EQ(data.byte, 0x62);
}

TEST_F(I2cAbi, SmbusWordWriteIsLittleEndian) {
  i2c_smbus_data data{};
  data.word = 0x0102;
  Decoded d = smbus(I2C_SMBUS_WRITE, 0x06, I2C_SMBUS_WORD_DATA, &data);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0x06, 0x02, 0x01}));
}

TEST_F(I2cAbi, SmbusBrokenBlockWriteIsTheGoPiGoFrame) {
  // python3-smbus write_i2c_block_data(0x08, 1, [0x77, 0, 0, 0]) on the wire: 01 77 00 00 00.
  state.addr = 0x08;
  i2c_smbus_data data{};
  data.block[0] = 4;
  data.block[1] = 0x77;
  Decoded d = smbus(I2C_SMBUS_WRITE, 0x01, I2C_SMBUS_I2C_BLOCK_BROKEN, &data);
  ASSERT_EQ(d.transfer.messages.size(), 1u);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0x01, 0x77, 0, 0, 0}));
}

TEST_F(I2cAbi, SmbusBlockDataWriteCarriesTheCount) {
  i2c_smbus_data data{};
  data.block[0] = 2;
  data.block[1] = 0xAA;
  data.block[2] = 0xBB;
  Decoded d = smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_BLOCK_DATA, &data);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0x10, 2, 0xAA, 0xBB}));
  data.block[0] = 33;
  EXPECT_EQ(smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_BLOCK_DATA, &data).err, EINVAL);
  EXPECT_EQ(smbus(I2C_SMBUS_WRITE, 0x10, I2C_SMBUS_I2C_BLOCK_DATA, &data).err, EINVAL);
}

TEST_F(I2cAbi, SmbusQuickAndByteWriteNeedNoData) {
  state.addr = 0x30;
  Decoded q = smbus(I2C_SMBUS_WRITE, 0, I2C_SMBUS_QUICK, nullptr);
  ASSERT_EQ(q.action, Decoded::Action::kTransfer);
  EXPECT_TRUE(q.transfer.quick);
  EXPECT_EQ(q.transfer.quick_addr, 0x30);
  Decoded b = smbus(I2C_SMBUS_WRITE, 0x06, I2C_SMBUS_BYTE, nullptr);
  ASSERT_EQ(b.action, Decoded::Action::kTransfer);
  EXPECT_EQ(b.transfer.messages[0].data, std::vector<uint8_t>{0x06});
  EXPECT_EQ(smbus(I2C_SMBUS_READ, 0, I2C_SMBUS_BYTE, nullptr).err, EINVAL);
}

TEST_F(I2cAbi, SmbusBadSizeOrDirectionIsEinval) {
  i2c_smbus_data data{};
  EXPECT_EQ(smbus(I2C_SMBUS_WRITE, 0, 9, &data).err, EINVAL);
  EXPECT_EQ(smbus(2, 0, I2C_SMBUS_BYTE_DATA, &data).err, EINVAL);
}

TEST_F(I2cAbi, SmbusByteDataReadRoundTrip) {
  state.addr = 0x40;
  i2c_smbus_data data{};
  data.word = 0xFFFF;
  Decoded d = smbus(I2C_SMBUS_READ, 0x00, I2C_SMBUS_BYTE_DATA, &data);
  ASSERT_EQ(d.transfer.messages.size(), 2u);
  EXPECT_EQ(d.transfer.messages[0].data, std::vector<uint8_t>{0x00});
  EXPECT_TRUE(d.transfer.messages[1].is_read());
  gate::TransferReply reply;
  reply.reads = {{0x11}};
  EXPECT_EQ(complete(d.completion, reply, mem), 0);
  EXPECT_EQ(data.byte, 0x11);
  EXPECT_EQ(data.block[1], 0xFF);  // only one byte is copied back for a byte read
}

TEST_F(I2cAbi, SmbusBlockReadsFillTheUnion) {
  i2c_smbus_data data{};
  Decoded d = smbus(I2C_SMBUS_READ, 0x01, I2C_SMBUS_I2C_BLOCK_BROKEN, &data);
  ASSERT_EQ(d.transfer.messages.size(), 2u);
  EXPECT_EQ(d.transfer.messages[1].len, 32);  // BROKEN reads are forced to 32 bytes
  gate::TransferReply reply;
  reply.reads = {std::vector<uint8_t>(32, 0x5A)};
  EXPECT_EQ(complete(d.completion, reply, mem), 0);
  EXPECT_EQ(data.block[0], 32);
  EXPECT_EQ(data.block[32], 0x5A);

  i2c_smbus_data blk{};
  Decoded b = smbus(I2C_SMBUS_READ, 0x02, I2C_SMBUS_BLOCK_DATA, &blk);
  EXPECT_TRUE(b.transfer.messages[1].flags & gate::kMsgRecvLen);
  reply.reads = {{3, 7, 8, 9}};
  EXPECT_EQ(complete(b.completion, reply, mem), 0);
  EXPECT_EQ(blk.block[0], 3);
  EXPECT_EQ(blk.block[3], 9);
  reply.reads = {{40}};
  EXPECT_EQ(complete(b.completion, reply, mem), -EPROTO);
}

TEST_F(I2cAbi, ProcCallWritesThenReadsTheWord) {
  i2c_smbus_data data{};
  data.word = 0x1234;
  Decoded d = smbus(I2C_SMBUS_WRITE, 0x05, I2C_SMBUS_PROC_CALL, &data);
  ASSERT_EQ(d.transfer.messages.size(), 2u);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0x05, 0x34, 0x12}));
  gate::TransferReply reply;
  reply.reads = {{0xCD, 0xAB}};
  EXPECT_EQ(complete(d.completion, reply, mem), 0);
  EXPECT_EQ(data.word, 0xABCD);
}

TEST_F(I2cAbi, RdwrLimitsAreTheKernels) {
  i2c_msg msgs[43] = {};
  uint8_t buf[4] = {1, 2, 3, 4};
  for (auto& m : msgs) {
    m.addr = 0x40;
    m.len = 1;
    m.buf = buf;
  }
  i2c_rdwr_ioctl_data a{msgs, 43};
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
  a.nmsgs = 0;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
  a.nmsgs = 42;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).action, Decoded::Action::kTransfer);
  msgs[5].len = 8193;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
  i2c_rdwr_ioctl_data null_msgs{nullptr, 1};
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&null_msgs), mem, 0).err, EINVAL);
}

TEST_F(I2cAbi, RdwrUsesEachMessagesAddressAndCopiesReadsBack) {
  state.addr = 0x11;  // ignored by I2C_RDWR
  uint8_t wbuf[2] = {0xFE, 0x79};
  uint8_t rbuf[1] = {0};
  i2c_msg msgs[2] = {};
  msgs[0] = {0x40, 0, 2, wbuf};
  msgs[1] = {0x41, I2C_M_RD, 1, rbuf};
  i2c_rdwr_ioctl_data a{msgs, 2};
  Decoded d = decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0);
  ASSERT_EQ(d.action, Decoded::Action::kTransfer);
  EXPECT_EQ(d.transfer.messages[0].addr, 0x40);
  EXPECT_EQ(d.transfer.messages[0].data, (std::vector<uint8_t>{0xFE, 0x79}));
  EXPECT_EQ(d.transfer.messages[1].addr, 0x41);
  // The copy is ours: changing the task's buffer afterwards changes nothing.
  wbuf[1] = 0x03;
  EXPECT_EQ(d.transfer.messages[0].data[1], 0x79);
  gate::TransferReply reply;
  reply.reads = {{0x42}};
  EXPECT_EQ(complete(d.completion, reply, mem), 2);
  EXPECT_EQ(rbuf[0], 0x42);
}

TEST_F(I2cAbi, RdwrRecvLenNeedsAPresetAndRoom) {
  uint8_t buf[40] = {1};
  i2c_msg m{0x40, I2C_M_RD | I2C_M_RECV_LEN, 40, buf};
  i2c_rdwr_ioctl_data a{&m, 1};
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).action, Decoded::Action::kTransfer);
  m.len = 20;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
  m.len = 40;
  buf[0] = 0;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
  m.flags = I2C_M_RECV_LEN;  // on a write
  buf[0] = 1;
  EXPECT_EQ(decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0).err, EINVAL);
}

// The shared allow-list (contego/i2c_msg_flags.h): a read carries only RD,
// TEN and RECV_LEN, a write only TEN; every other bit, each alone, is EINVAL
// at the decoder, before anything is decided or sent.
TEST_F(I2cAbi, RdwrRefusesEveryFlagOutsideTheAllowList) {
  uint8_t buf[40] = {1};
  for (unsigned bit = 0; bit < 16; ++bit) {
    const auto flag = static_cast<uint16_t>(1u << bit);
    for (const bool read : {true, false}) {
      i2c_msg m{0x40, static_cast<uint16_t>(flag | (read ? I2C_M_RD : 0)), 2, buf};
      if (flag == I2C_M_RECV_LEN) m.len = 40;
      i2c_rdwr_ioctl_data a{&m, 1};
      const Decoded d = decode_ioctl(state, I2C_RDWR, addr_of(&a), mem, 0);
      const bool allowed =
          flag == I2C_M_RD || flag == I2C_M_TEN || (read && flag == I2C_M_RECV_LEN);
      if (allowed) {
        EXPECT_EQ(d.action, Decoded::Action::kTransfer) << std::hex << flag << " read " << read;
      } else {
        EXPECT_EQ(d.err, EINVAL) << std::hex << flag << " read " << read;
      }
    }
  }
}

TEST_F(I2cAbi, PlainWriteGoesToTheSlaveAddressCappedAt8192) {
  state.addr = 0x08;
  uint8_t frame[5] = {0x01, 0x77, 0, 0, 0};
  Decoded d = decode_write(state, addr_of(frame), 5, mem);
  EXPECT_EQ(d.transfer.messages[0].addr, 0x08);
  EXPECT_EQ(d.transfer.messages[0].data.size(), 5u);
  gate::TransferReply ok;
  EXPECT_EQ(complete(d.completion, ok, mem), 5);
  std::vector<uint8_t> big(9000);
  Decoded b = decode_write(state, addr_of(big.data()), big.size(), mem);
  EXPECT_EQ(b.transfer.messages[0].data.size(), 8192u);
  gate::TransferReply nack;
  nack.err = EREMOTEIO;
  EXPECT_EQ(complete(b.completion, nack, mem), -EREMOTEIO);
}

TEST_F(I2cAbi, FreshDescriptorWritesToTheGeneralCallAddress) {
  uint8_t reset = 0x06;
  Decoded d = decode_write(state, addr_of(&reset), 1, mem);
  EXPECT_EQ(d.transfer.messages[0].addr, 0);
}

TEST_F(I2cAbi, PlainReadCopiesBack) {
  state.addr = 0x06;
  uint8_t buf[10] = {};
  Decoded d = decode_read(state, addr_of(buf), 10);
  EXPECT_TRUE(d.transfer.messages[0].is_read());
  EXPECT_EQ(d.transfer.messages[0].len, 10);
  gate::TransferReply reply;
  reply.reads = {{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}};
  EXPECT_EQ(complete(d.completion, reply, mem), 10);
  EXPECT_EQ(buf[9], 10);
}

}  // namespace
}  // namespace contego::intercept::i2c_abi
