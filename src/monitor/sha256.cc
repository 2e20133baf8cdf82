// SHA256_Init and friends are deprecated in OpenSSL 3 (kept, not removed):
// see sha256_hex below for why this file uses them.
#define OPENSSL_SUPPRESS_DEPRECATED 1

#include "monitor/sha256.h"

#include <cstdint>
#include <cstdlib>
#include <openssl/sha.h>

namespace contego::monitor {
namespace {

void to_hex(const uint8_t* digest, char out[65]) {
  static const char* digits = "0123456789abcdef";
  for (int i = 0; i < 32; ++i) {
    out[2 * i] = digits[digest[i] >> 4];
    out[2 * i + 1] = digits[digest[i] & 15];
  }
  out[64] = 0;
}

}  // namespace

void sha256_hex(std::string_view text, char out[65]) {
  // libcrypto's own SHA-256 functions, not EVP: a record's hash is on the
  // path of every checked command, and EVP's provider dispatch cost as much
  // as hashing a 64-byte line (bench/monitor_bench, BM_AuditLineHash). Same
  // compression function (SHA-NI where the CPU has it); deprecated in
  // OpenSSL 3 but kept there (OPENSSL_SUPPRESS_DEPRECATED above).
  SHA256_CTX ctx;
  uint8_t d[32];
  if (SHA256_Init(&ctx) != 1 || SHA256_Update(&ctx, text.data(), text.size()) != 1 ||
      SHA256_Final(d, &ctx) != 1) {
    std::abort();
  }
  to_hex(d, out);
}

std::string sha256_hex(std::string_view text) {
  char out[65];
  sha256_hex(text, out);
  return std::string(out, 64);
}

}  // namespace contego::monitor
