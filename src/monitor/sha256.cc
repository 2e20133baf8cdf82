// SHA256_Init and friends are deprecated in OpenSSL 3 (kept, not removed):
// see sha256_hex below for why this file uses them.
#define OPENSSL_SUPPRESS_DEPRECATED 1

#include "monitor/sha256.h"

#include <cstdlib>
#include <openssl/evp.h>
#include <openssl/sha.h>

namespace contego::monitor {
namespace {

// Fetched once: a per-call fetch costs more than hashing a record.
const EVP_MD* sha256_md() {
  static EVP_MD* md = EVP_MD_fetch(nullptr, "SHA256", nullptr);
  if (md == nullptr) std::abort();  // libcrypto without SHA-256: nothing can be audited
  return md;
}

void to_hex(const uint8_t* digest, char out[65]) {
  static const char* digits = "0123456789abcdef";
  for (int i = 0; i < 32; ++i) {
    out[2 * i] = digits[digest[i] >> 4];
    out[2 * i + 1] = digits[digest[i] & 15];
  }
  out[64] = 0;
}

}  // namespace

Sha256::Sha256() : ctx_(EVP_MD_CTX_new()) {
  if (ctx_ == nullptr || EVP_DigestInit_ex(ctx_, sha256_md(), nullptr) != 1) std::abort();
}

Sha256::~Sha256() { EVP_MD_CTX_free(ctx_); }

void Sha256::update(const void* data, size_t len) {
  if (EVP_DigestUpdate(ctx_, data, len) != 1) std::abort();
}

std::array<uint8_t, 32> Sha256::finish() {
  std::array<uint8_t, 32> d{};
  unsigned n = 0;
  if (EVP_DigestFinal_ex(ctx_, d.data(), &n) != 1 || n != d.size()) std::abort();
  return d;
}

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
