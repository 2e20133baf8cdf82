// Pure decoding of the Linux i2c-dev user ABI (drivers/i2c/i2c-dev.c): turns
// the arguments of ioctl(), read() and write() on a /dev/i2c-N descriptor
// into a gate::Transfer, and writes a transfer's results back the way the
// kernel does. Every argument check answers the errno the kernel answers
// (EINVAL, ENOTTY, EFAULT), so a program cannot tell the emulation from the
// real device node.
//
// The task's memory is reached only through `Memory`, so the same code runs
// in the seccomp supervisor (process_vm_readv), in the preload library
// (memcpy) and in the fuzzer (a byte buffer). Each byte of the task is read
// exactly once; the Transfer owns the copy that is checked and performed.
//
// Thread-safety: none (per-descriptor state is owned by the caller).
#ifndef CONTEGO_INTERCEPT_I2C_ABI_I2C_ABI_H_
#define CONTEGO_INTERCEPT_I2C_ABI_I2C_ABI_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "contego/i2c_plan.h"

#include "gate/transfer.h"

namespace contego::intercept::i2c_abi {

// ioctl request numbers (plain constants in <linux/i2c-dev.h>).
inline constexpr unsigned long kI2cRetries = 0x0701;
inline constexpr unsigned long kI2cTimeout = 0x0702;
inline constexpr unsigned long kI2cSlave = 0x0703;
inline constexpr unsigned long kI2cTenbit = 0x0704;
inline constexpr unsigned long kI2cFuncs = 0x0705;
inline constexpr unsigned long kI2cSlaveForce = 0x0706;
inline constexpr unsigned long kI2cRdwr = 0x0707;
inline constexpr unsigned long kI2cPec = 0x0708;
inline constexpr unsigned long kI2cSmbus = 0x0720;

// SMBus sizes and directions.
inline constexpr uint32_t kSmbusQuick = 0;
inline constexpr uint32_t kSmbusByte = 1;
inline constexpr uint32_t kSmbusByteData = 2;
inline constexpr uint32_t kSmbusWordData = 3;
inline constexpr uint32_t kSmbusProcCall = 4;
inline constexpr uint32_t kSmbusBlockData = 5;
inline constexpr uint32_t kSmbusI2cBlockBroken = 6;
inline constexpr uint32_t kSmbusBlockProcCall = 7;
inline constexpr uint32_t kSmbusI2cBlockData = 8;
inline constexpr uint8_t kSmbusRead = 1;
inline constexpr uint8_t kSmbusWrite = 0;
inline constexpr size_t kSmbusDataSize = 34;  // union i2c_smbus_data

// Access to the task's address space. Both return false if any byte is
// unreachable (the caller answers EFAULT).
class Memory {
 public:
  virtual ~Memory() = default;
  virtual bool read(uint64_t addr, void* dst, size_t len) = 0;
  virtual bool write(uint64_t addr, const void* src, size_t len) = 0;
};

// What i2c-dev keeps per open file (struct i2c_client): shared by dup()s and
// by a forked child, fresh for every open().
struct FdState {
  uint8_t bus = 0;
  uint16_t addr = 0;  // 0 until I2C_SLAVE: a bare write() goes to the general call address
  bool ten_bit = false;
  bool pec = false;
  // I2C_RETRIES and I2C_TIMEOUT, this descriptor's own once it set either
  // (own_timing; i2c-dev's are the adapter's): sent with each transfer.
  // Until then, i2c-core's defaults: no retries, and the timeout of an
  // adapter that sets none (the adapter's own cannot be read).
  uint32_t retries = 0;
  uint32_t timeout_10ms = CONTEGO_I2C_ADAPTER_TIMEOUT_MS / CONTEGO_I2C_TIMEOUT_UNIT_MS;
  bool own_timing = false;
};

// How to hand a transfer's results back to the task.
struct Completion {
  enum class Form : uint8_t { kWrite, kRead, kRdwr, kSmbus } form = Form::kWrite;
  uint32_t count = 0;               // kWrite/kRead: bytes; kRdwr: messages
  uint64_t read_buf = 0;            // kRead: destination
  std::vector<uint64_t> read_bufs;  // kRdwr: destination of each read message, in order
  uint64_t smbus_data = 0;          // kSmbus: the union's address (0: nothing to copy back)
  uint32_t smbus_size = 0;          // kSmbus: size after BROKEN was rewritten to I2C_BLOCK_DATA
  uint8_t smbus_read_write = 0;
  size_t smbus_datasize = 0;    // bytes the kernel copies back (1, 2 or 34)
  uint8_t smbus_block_len = 0;  // I2C_BLOCK_DATA read: requested length
  // kSmbus read with PEC: the answer's last byte is the device's PEC, to be
  // compared with contego_smbus_pec(smbus_pec_partial, the bytes before it).
  bool smbus_pec = false;
  uint8_t smbus_pec_partial = 0;  // over the messages before, and the read's address byte
};

// The outcome of decoding one call.
struct Decoded {
  enum class Action : uint8_t {
    kReturn,    // answer `value` (>= 0) or `-err` now; fd state may have changed
    kTransfer,  // perform `transfer` on the trusted side, then complete()
  } action = Action::kReturn;
  int err = 0;        // errno for kReturn when non-zero
  int64_t value = 0;  // return value for kReturn when err == 0
  gate::Transfer transfer;
  Completion completion;
};

// ioctl(fd, request, arg). `funcs` is the adapter's I2C_FUNCS mask;
// `address_busy` says whether a kernel driver owns an address (EBUSY for
// I2C_SLAVE; I2C_SLAVE_FORCE ignores it). May be null.
Decoded decode_ioctl(FdState& state, unsigned long request, uint64_t arg, Memory& memory,
                     uint64_t funcs, bool (*address_busy)(uint8_t bus, uint16_t addr) = nullptr);

// write(fd, buf, count) / read(fd, buf, count): one message to state.addr,
// count silently capped at 8192.
Decoded decode_write(const FdState& state, uint64_t buf, uint64_t count, Memory& memory);
Decoded decode_read(const FdState& state, uint64_t buf, uint64_t count);

// Writes the results back (for reads) and returns the syscall's result:
// >= 0, or -errno.
int64_t complete(const Completion& completion, const gate::TransferReply& reply, Memory& memory);

// Memory backed by the caller's own address space (preload library, tests).
class LocalMemory final : public Memory {
 public:
  bool read(uint64_t addr, void* dst, size_t len) override;
  bool write(uint64_t addr, const void* src, size_t len) override;
};

}  // namespace contego::intercept::i2c_abi

#endif  // CONTEGO_INTERCEPT_I2C_ABI_I2C_ABI_H_
