#include "monitor/sha256.h"

#include <cstdlib>
#include <openssl/evp.h>

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
  // One context per thread, reset for every line: no allocation per record.
  thread_local struct Ctx {
    EVP_MD_CTX* ctx = EVP_MD_CTX_new();
    ~Ctx() { EVP_MD_CTX_free(ctx); }
  } t;
  uint8_t d[32];
  unsigned n = 0;
  if (t.ctx == nullptr || EVP_DigestInit_ex(t.ctx, sha256_md(), nullptr) != 1 ||
      EVP_DigestUpdate(t.ctx, text.data(), text.size()) != 1 ||
      EVP_DigestFinal_ex(t.ctx, d, &n) != 1 || n != 32) {
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
