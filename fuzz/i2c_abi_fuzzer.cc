// Fuzzes the i2c-dev argument decoder: arbitrary requests and arguments over
// an arbitrary task memory image, then a completion with arbitrary read data.
// Input: [selector][arg: 8 bytes][count: 2 bytes][memory image...]
// (selector: request in bits 0-3, the adapter's PEC 0x10, the descriptor's
// I2C_PEC 0x20, ten-bit 0x40, a pointer into the image 0x80); the
// memory image is mapped at kBase, everything else faults (EFAULT paths).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "gate/transfer.h"
#include "intercept/i2c_abi/i2c_abi.h"

namespace {

using namespace contego;
using namespace contego::intercept::i2c_abi;

constexpr uint64_t kBase = 0x10000;

class FuzzMemory final : public Memory {
 public:
  explicit FuzzMemory(std::vector<uint8_t> image) : image_(std::move(image)) {}
  bool read(uint64_t addr, void* dst, size_t len) override {
    if (addr < kBase || addr - kBase > image_.size() || len > image_.size() - (addr - kBase)) {
      return false;
    }
    std::memcpy(dst, image_.data() + (addr - kBase), len);
    return true;
  }
  bool write(uint64_t addr, const void* src, size_t len) override {
    if (addr < kBase || addr - kBase > image_.size() || len > image_.size() - (addr - kBase)) {
      return false;
    }
    std::memcpy(image_.data() + (addr - kBase), src, len);
    return true;
  }

 private:
  std::vector<uint8_t> image_;
};

constexpr unsigned long kRequests[] = {kI2cRetries, kI2cTimeout,    kI2cSlave, kI2cTenbit,
                                       kI2cFuncs,   kI2cSlaveForce, kI2cRdwr,  kI2cPec,
                                       kI2cSmbus,   0x5401};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 11) return 0;
  const uint8_t selector = data[0];
  uint64_t arg = 0;
  std::memcpy(&arg, data + 1, 8);
  // Pointers mostly land inside the image so the deep paths are reached.
  if (selector & 0x80) arg = kBase + (arg % (size + 1));
  const uint16_t count = static_cast<uint16_t>(data[9] | (data[10] << 8));
  FuzzMemory mem(std::vector<uint8_t>(data + 11, data + size));
  FdState state;
  state.ten_bit = (selector & 0x40) != 0;
  // I2C_PEC set: SMBus writes carry a PEC byte and reads check one.
  state.pec = (selector & 0x20) != 0;
  state.addr = static_cast<uint16_t>(count & 0x3FF);
  // A plain adapter with I2C_FUNC_SMBUS_PEC (0x8), as i2c-core's emulation gives it, or without.
  const uint64_t funcs = (selector & 0x10) != 0 ? 0x0FFF8009 : 0x0FFF8001;
  Decoded d;
  const uint8_t which = selector & 0x0F;
  if (which < 10) {
    d = decode_ioctl(state, kRequests[which], arg, mem, funcs);
  } else if (which == 10) {
    d = decode_write(state, arg, count, mem);
  } else {
    d = decode_read(state, arg, count);
  }
  if (d.action != Decoded::Action::kTransfer) return 0;
  (void)gate::validate(d.transfer);
  const auto txs = gate::to_transactions(d.transfer);
  for (const auto& tx : txs) {
    if (tx.first_message + tx.message_count > d.transfer.messages.size() && !d.transfer.quick) {
      __builtin_trap();  // a planned transaction must cover existing messages
    }
  }
  // A reply whose read data come from the input too (short, long, empty).
  gate::TransferReply reply;
  size_t offset = 0;
  for (const auto& m : d.transfer.messages) {
    if (!m.is_read()) continue;
    const size_t n = size > 11 ? (data[11 + offset % (size - 11)] % (m.len + 2u)) : 0;
    reply.reads.emplace_back(n, static_cast<uint8_t>(offset));
    ++offset;
  }
  (void)complete(d.completion, reply, mem);
  return 0;
}
