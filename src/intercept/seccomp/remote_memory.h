// The supervised program's memory as the supervisor reads and writes it
// (process_vm_readv/writev), and the reads of a path from it.
#ifndef CONTEGO_INTERCEPT_SECCOMP_REMOTE_MEMORY_H_
#define CONTEGO_INTERCEPT_SECCOMP_REMOTE_MEMORY_H_

#include <cstdint>
#include <functional>
#include <string>
#include <sys/types.h>
#include <sys/uio.h>

#include "intercept/i2c_abi/i2c_abi.h"

namespace contego::intercept::seccomp {

class RemoteMemory final : public i2c_abi::Memory {
 public:
  explicit RemoteMemory(pid_t pid) : pid_(pid) {}
  bool read(uint64_t addr, void* dst, size_t len) override {
    if (len == 0) return true;
    iovec local{dst, len};
    // NOLINTNEXTLINE(performance-no-int-to-ptr): an address in the supervised program
    iovec remote{reinterpret_cast<void*>(addr), len};
    return process_vm_readv(pid_, &local, 1, &remote, 1, 0) == static_cast<ssize_t>(len);
  }
  bool write(uint64_t addr, const void* src, size_t len) override {
    if (len == 0) return true;
    iovec local{const_cast<void*>(src), len};
    // NOLINTNEXTLINE(performance-no-int-to-ptr): an address in the supervised program
    iovec remote{reinterpret_cast<void*>(addr), len};
    return process_vm_writev(pid_, &local, 1, &remote, 1, 0) == static_cast<ssize_t>(len);
  }

 private:
  pid_t pid_;
};

// Writes into the program only after `still_valid` said yes (asked once).
class ValidatedWrites final : public i2c_abi::Memory {
 public:
  template <typename F>
  ValidatedWrites(i2c_abi::Memory& inner, F still_valid)
      : inner_(inner), still_valid_(std::move(still_valid)) {}
  bool read(uint64_t addr, void* dst, size_t len) override { return inner_.read(addr, dst, len); }
  bool write(uint64_t addr, const void* src, size_t len) override {
    if (!checked_) {
      if (!still_valid_()) return false;
      checked_ = true;
    }
    return inner_.write(addr, src, len);
  }

 private:
  i2c_abi::Memory& inner_;
  std::function<bool()> still_valid_;
  bool checked_ = false;
};

// A NUL-terminated path of at most PATH_MAX bytes at `addr`; false if it
// cannot be read or is longer.
bool read_path(i2c_abi::Memory& mem, uint64_t addr, std::string* out);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_REMOTE_MEMORY_H_
