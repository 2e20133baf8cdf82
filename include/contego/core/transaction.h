// A bus transaction, normalised by an enclave client from whatever system
// call the task made (write(), I2C_SMBUS of any size, one message of
// I2C_RDWR). The core checks transactions; it never sees system calls.
#ifndef CONTEGO_CORE_TRANSACTION_H_
#define CONTEGO_CORE_TRANSACTION_H_

#include <stdint.h>

namespace contego::core {

inline constexpr uint16_t kNoTask = 0xFFFF;  // a client that is no declared task

enum class TxKind : uint8_t {
  kWrite = 1,  // `bytes` are the bytes on the wire after the address (SMBus forms expanded:
               // BYTE_DATA [cmd, b], WORD_DATA [cmd, lo, hi], BLOCK_DATA [cmd, n, ...],
               // I2C_BLOCK [cmd, ...], BYTE [cmd], PROC_CALL [cmd, lo, hi])
  kRead = 2,   // a read; `bytes` are the register-pointer bytes written first (may be empty)
  kQuick = 3,  // SMBus quick: address and R/W bit only, no data
};

struct Transaction {
  uint16_t task;  // task id from the image, or kNoTask
  uint8_t bus;    // i2c-N
  TxKind kind;
  uint16_t addr;  // 7-bit address (or 10-bit when ten_bit)
  uint8_t ten_bit;
  uint8_t pad;
  uint32_t job;          // job sequence number of the task (from its periodic sleeps);
                         // 0 = unknown: the core uses windows of the task's period
  uint32_t len;          // bytes in `bytes`
  const uint8_t* bytes;  // the trusted side's own copy; not kept after check() returns
  uint64_t now_us;       // monotonic time of the request, microseconds
};

}  // namespace contego::core

#endif  // CONTEGO_CORE_TRANSACTION_H_
