// contego/i2c_plan.h: an I2C_SMBUS call as the messages it puts on the
// wire, i2c-core's SMBus emulation's table, shared by contego.ko and the
// user-space decoder. Freestanding.
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

extern "C" uint8_t contego_smbus_pec(uint8_t crc, const uint8_t* bytes, uint32_t n) {
  for (uint32_t i = 0; i < n; ++i) {
    crc ^= bytes[i];
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<uint8_t>((crc & 0x80) != 0 ? (crc << 1) ^ 0x07 : crc << 1);
    }
  }
  return crc;
}

extern "C" uint8_t contego_i2c_answer_pec(const contego_i2c_msg* m, uint32_t n) {
  uint8_t pec = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const bool reads = (m[i].flags & CONTEGO_I2C_M_RD) != 0;
    const auto address_byte = static_cast<uint8_t>((m[i].addr << 1) | (reads ? 1 : 0));
    pec = contego_smbus_pec(pec, &address_byte, 1);
    if (i + 1 < n) pec = contego_smbus_pec(pec, m[i].buf, m[i].len);
  }
  return pec;
}

extern "C" int contego_i2c_smbus_msgs(uint16_t addr, uint16_t client_flags, uint8_t read,
                                      uint8_t command, uint32_t size,
                                      const uint8_t data[CONTEGO_SMBUS_DATA_BYTES],
                                      struct contego_i2c_msg m[2],
                                      uint8_t wire[CONTEGO_SMBUS_WIRE_BYTES],
                                      uint8_t rbuf[CONTEGO_SMBUS_DATA_BYTES - 1]) {
  constexpr int kEinval = -22;
  constexpr uint32_t kMax = CONTEGO_SMBUS_BLOCK_MAX;
  const uint16_t flags = client_flags & CONTEGO_I2C_M_TEN, rd = flags | CONTEGO_I2C_M_RD;
  // One byte more, the PEC: after a write's bytes, or from the device after a read's.
  const uint16_t pec =
      (client_flags & CONTEGO_I2C_CLIENT_PEC) != 0 && contego_i2c_smbus_pec_kept(size, read) ? 1
                                                                                             : 0;
  const bool proc = size == CONTEGO_SMBUS_PROC_CALL || size == CONTEGO_SMBUS_BLOCK_PROC_CALL;
  uint32_t len = 1;  // the write's: the command byte, then the data
  wire[0] = command;
  rbuf[0] = 1;  // RECV_LEN's preset, as i2c-dev's callers set it
  switch (size) {
    case CONTEGO_SMBUS_QUICK:  // the address and the R/W bit only
      m[0] = {addr, static_cast<uint16_t>(read ? rd : flags), 0, nullptr};
      return 1;
    case CONTEGO_SMBUS_BYTE:  // send byte (the command alone), or receive byte
      if (!read) break;
      m[0] = {addr, rd, static_cast<uint16_t>(1 + pec), rbuf};
      return 1;
    case CONTEGO_SMBUS_BYTE_DATA:
    case CONTEGO_SMBUS_WORD_DATA:
    case CONTEGO_SMBUS_PROC_CALL: {
      const uint32_t n = size == CONTEGO_SMBUS_BYTE_DATA ? 1 : 2;
      if (read && !proc) {
        m[0] = {addr, flags, 1, wire};
        m[1] = {addr, rd, static_cast<uint16_t>(n + pec), rbuf};
        return 2;
      }
      for (uint32_t i = 0; i < n; ++i) wire[len++] = data[i];
      break;
    }
    case CONTEGO_SMBUS_BLOCK_DATA:
    case CONTEGO_SMBUS_BLOCK_PROC_CALL:
      if (read && !proc) {  // the count comes from the device
        m[0] = {addr, flags, 1, wire};
        m[1] = {addr, static_cast<uint16_t>(rd | CONTEGO_I2C_M_RECV_LEN), 1 + kMax, rbuf};
        return 2;
      }
      if (data[0] > kMax) return kEinval;
      for (uint32_t i = 0; i <= data[0]; ++i) wire[len++] = data[i];  // the count, then the data
      break;
    case CONTEGO_SMBUS_I2C_BLOCK_DATA:  // data[0]: the length, not sent
      if (data[0] > kMax) return kEinval;
      if (read) {
        m[0] = {addr, flags, 1, wire};
        m[1] = {addr, rd, data[0], rbuf};
        return 2;
      }
      for (uint32_t i = 1; i <= data[0]; ++i) wire[len++] = data[i];
      break;
    default:
      return kEinval;
  }
  if (pec != 0 && !proc) {
    const uint8_t address_byte = static_cast<uint8_t>(addr << 1);  // i2c_8bit_addr_from_msg
    wire[len] = contego_smbus_pec(contego_smbus_pec(0, &address_byte, 1), wire, len);
    ++len;
  }
  m[0] = {addr, flags, static_cast<uint16_t>(len), wire};
  if (!proc) return 1;
  // A process call's answer: a read without pointer after the write.
  m[1] = size == CONTEGO_SMBUS_PROC_CALL
             ? contego_i2c_msg{addr, rd, static_cast<uint16_t>(2 + pec), rbuf}
             : contego_i2c_msg{addr, static_cast<uint16_t>(rd | CONTEGO_I2C_M_RECV_LEN), 1 + kMax,
                               rbuf};
  return 2;
}
