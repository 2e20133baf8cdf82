// SHA-256 (FIPS 180-4) for the audit log's hash chain. Host code, backed by
// OpenSSL's libcrypto, which uses the CPU's SHA extensions where it has them
// (x86 SHA-NI, Armv8 crypto): a record's hash is on the path of every
// checked command (docs/libraries.md).
#ifndef CONTEGO_MONITOR_SHA256_H_
#define CONTEGO_MONITOR_SHA256_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

struct evp_md_ctx_st;

namespace contego::monitor {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(const void* data, size_t len);
  std::array<uint8_t, 32> finish();

 private:
  evp_md_ctx_st* ctx_;
};

// Lower-case hex digest of `text`.
std::string sha256_hex(std::string_view text);
// The same into `out` (64 digits and a NUL), without allocating.
void sha256_hex(std::string_view text, char out[65]);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_SHA256_H_
