// SHA-256 (FIPS 180-4) for the audit log's hash chain. Host code; small and
// dependency-free so the monitor needs no crypto library.
#ifndef CONTEGO_MONITOR_SHA256_H_
#define CONTEGO_MONITOR_SHA256_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace contego::monitor {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, size_t len);
  std::array<uint8_t, 32> finish();

 private:
  void block(const uint8_t* p);
  uint32_t h_[8];
  uint8_t buf_[64];
  size_t used_ = 0;
  uint64_t total_ = 0;
};

// Lower-case hex digest of `text`.
std::string sha256_hex(std::string_view text);
// The same into `out` (64 digits and a NUL), without allocating.
void sha256_hex(std::string_view text, char out[65]);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_SHA256_H_
