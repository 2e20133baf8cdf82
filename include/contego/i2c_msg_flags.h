/* The flags an i2c_msg may carry through contego: one allow-list, shared by
 * every entry point of both enclave clients (the i2c ioctl decoder of
 * `contego run` and the preload client, the monitor's gate, the bus that
 * sends, and contego.ko). Freestanding C: no includes, usable in the kernel.
 *
 * Why an allow-list: a checked register read must stay a read. The protocol
 * mangling flags (I2C_M_NOSTART, I2C_M_REV_DIR_ADDR, I2C_M_IGNORE_NAK,
 * I2C_M_NO_RD_ACK, I2C_M_STOP) change what goes on the wire: on an adapter
 * that honours them (a bit-banged one, I2C_FUNC_PROTOCOL_MANGLING) a read
 * with I2C_M_REV_DIR_ADDR is sent as a write, which the checker never saw.
 * Nothing the vendors' libraries send carries them (smbus2, Adafruit_PureIO,
 * i2c-tools: 0 or I2C_M_RD, I2C_M_TEN, I2C_M_RECV_LEN), so any other bit is
 * refused with EINVAL before anything is decided or sent. */
#ifndef CONTEGO_I2C_MSG_FLAGS_H_
#define CONTEGO_I2C_MSG_FLAGS_H_

/* <linux/i2c.h>'s values, which are ABI. */
#define CONTEGO_I2C_M_RD 0x0001u
#define CONTEGO_I2C_M_TEN 0x0010u
#define CONTEGO_I2C_M_DMA_SAFE 0x0200u
#define CONTEGO_I2C_M_RECV_LEN 0x0400u
#define CONTEGO_I2C_M_NO_RD_ACK 0x0800u
#define CONTEGO_I2C_M_IGNORE_NAK 0x1000u
#define CONTEGO_I2C_M_REV_DIR_ADDR 0x2000u
#define CONTEGO_I2C_M_NOSTART 0x4000u
#define CONTEGO_I2C_M_STOP 0x8000u

/* What a read and a write message may carry. */
#define CONTEGO_I2C_READ_FLAGS (CONTEGO_I2C_M_RD | CONTEGO_I2C_M_TEN | CONTEGO_I2C_M_RECV_LEN)
#define CONTEGO_I2C_WRITE_FLAGS (CONTEGO_I2C_M_TEN)

/* The bits of `flags` the allow-list refuses (0: the message may pass). */
static inline unsigned contego_i2c_refused_flags(unsigned flags) {
  return flags & ~((flags & CONTEGO_I2C_M_RD) ? CONTEGO_I2C_READ_FLAGS : CONTEGO_I2C_WRITE_FLAGS);
}

/* The refused flag's name, for messages and audit (the lowest refused bit). */
static inline const char *contego_i2c_flag_name(unsigned flag) {
  switch (flag & (0u - flag)) {
    case CONTEGO_I2C_M_RD:
      return "I2C_M_RD";
    case CONTEGO_I2C_M_TEN:
      return "I2C_M_TEN";
    case CONTEGO_I2C_M_DMA_SAFE:
      return "I2C_M_DMA_SAFE";
    case CONTEGO_I2C_M_RECV_LEN:
      return "I2C_M_RECV_LEN";
    case CONTEGO_I2C_M_NO_RD_ACK:
      return "I2C_M_NO_RD_ACK";
    case CONTEGO_I2C_M_IGNORE_NAK:
      return "I2C_M_IGNORE_NAK";
    case CONTEGO_I2C_M_REV_DIR_ADDR:
      return "I2C_M_REV_DIR_ADDR";
    case CONTEGO_I2C_M_NOSTART:
      return "I2C_M_NOSTART";
    case CONTEGO_I2C_M_STOP:
      return "I2C_M_STOP";
    default:
      return "an unknown flag";
  }
}

#endif /* CONTEGO_I2C_MSG_FLAGS_H_ */
