#include "bundle/minisign.h"

#include <algorithm>
#include <exception>
#include <filesystem>
#include <memory>
#include <openssl/err.h>
#include <openssl/evp.h>

#include "base/read_file.h"

namespace contego::bundle {
namespace {

constexpr std::string_view kUntrustedPrefix = "untrusted comment: ";
constexpr std::string_view kTrustedPrefix = "trusted comment: ";
// A key file is about 100 bytes plus its comment; far above any real one.
constexpr size_t kMaxKeyFileBytes = 64u << 10;

// Text from an input, quoted in a message: printable ASCII as is, anything
// else escaped, long text cut (an input must not be able to flood a log).
std::string quote(std::string_view text, size_t max = 40) {
  std::string out = "'";
  for (size_t i = 0; i < text.size() && i < max; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f && c != '\'' && c != '\\') {
      out += static_cast<char>(c);
    } else {
      static const char* digits = "0123456789abcdef";
      out += "\\x";
      out += digits[c >> 4];
      out += digits[c & 15];
    }
  }
  if (text.size() > max) out += "...";
  return out + "'";
}

// The file's lines without their LF (or CRLF: a file edited on Windows says
// the same). Exactly `count` lines must be there; after them only empty ones.
Result<std::vector<std::string_view>> split_lines(std::string_view text, const std::string& source,
                                                  size_t count, const char* what) {
  std::vector<std::string_view> lines;
  size_t start = 0;
  while (start < text.size()) {
    size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    start = end + 1;
  }
  if (lines.empty()) return make_error(source + ": empty; expected " + what);
  if (lines.size() < count) {
    return make_error(source + ": " + std::to_string(lines.size()) + " line(s); expected " +
                      std::to_string(count) + " in " + what);
  }
  for (size_t i = count; i < lines.size(); ++i) {
    if (!lines[i].empty()) {
      return make_error(source + ": line " + std::to_string(i + 1) + ": unexpected text after " +
                        what + ": " + quote(lines[i]));
    }
  }
  lines.resize(count);
  return lines;
}

int base64_value(char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

// Strict base64 as minisign writes it (standard alphabet, padded, nothing
// else on the line): exactly one byte string has a given text, so a file
// cannot carry bytes its reader and the tool would see differently.
Result<std::vector<uint8_t>> decode_base64(std::string_view in) {
  if (in.empty()) return make_error("invalid base64: empty line");
  for (size_t i = 0; i < in.size(); ++i) {
    if (base64_value(in[i]) < 0 && in[i] != '=') {
      return make_error("invalid base64: character " + quote(in.substr(i, 1)) + " at column " +
                        std::to_string(i + 1));
    }
  }
  if (const size_t eq = in.find('=');
      eq != std::string_view::npos && (eq + 2 < in.size() || in.back() != '=')) {
    return make_error("invalid base64: padding '=' before the end, at column " +
                      std::to_string(eq + 1));
  }
  if (in.size() % 4 != 0) {
    return make_error("invalid base64: " + std::to_string(in.size()) +
                      " characters, not a multiple of 4");
  }
  const size_t pad = in.back() != '=' ? 0 : in[in.size() - 2] == '=' ? 2 : 1;
  std::vector<uint8_t> out;
  out.reserve(in.size() / 4 * 3);
  uint32_t acc = 0;
  for (size_t i = 0; i < in.size() - pad; ++i) {
    acc = (acc << 6) | static_cast<uint32_t>(base64_value(in[i]));
    if (i % 4 == 3) {
      out.push_back(static_cast<uint8_t>(acc >> 16));
      out.push_back(static_cast<uint8_t>(acc >> 8));
      out.push_back(static_cast<uint8_t>(acc));
      acc = 0;
    }
  }
  if (pad == 2) {  // 12 bits, the last 4 unused
    if ((acc & 0xf) != 0) return make_error("invalid base64: non-zero bits in the padding");
    out.push_back(static_cast<uint8_t>(acc >> 4));
  } else if (pad == 1) {  // 18 bits, the last 2 unused
    if ((acc & 0x3) != 0) return make_error("invalid base64: non-zero bits in the padding");
    out.push_back(static_cast<uint8_t>(acc >> 10));
    out.push_back(static_cast<uint8_t>(acc >> 2));
  }
  return out;
}

// Line `number` of `source`, decoded: it must be exactly `size` bytes long.
Result<std::vector<uint8_t>> decode_line(std::string_view line, const std::string& source,
                                         int number, size_t size, const char* what) {
  const std::string where = source + ": line " + std::to_string(number) + ": ";
  Result<std::vector<uint8_t>> bytes = decode_base64(line);
  if (!bytes) return make_error(where + bytes.error() + " (expected " + what + ")");
  if (bytes->size() != size) {
    return make_error(where + "decodes to " + std::to_string(bytes->size()) + " bytes; expected " +
                      std::to_string(size) + " (" + what + ")");
  }
  return bytes;
}

struct PkeyFree {
  void operator()(EVP_PKEY* p) const { EVP_PKEY_free(p); }
};
struct MdCtxFree {
  void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
};

// Whether `sig` is `key`'s Ed25519 signature of `data`; an error only when
// libcrypto itself fails (out of memory, no Ed25519 in its providers).
Result<bool> ed25519_verify(const std::array<uint8_t, 32>& key, const uint8_t* sig,
                            std::string_view data) {
  static const unsigned char kEmpty = 0;  // libcrypto wants a pointer even for nothing
  const auto* bytes = data.empty() ? &kEmpty : reinterpret_cast<const unsigned char*>(data.data());
  std::unique_ptr<EVP_PKEY, PkeyFree> pkey(
      EVP_PKEY_new_raw_public_key(EVP_PKEY_ED25519, nullptr, key.data(), key.size()));
  std::unique_ptr<EVP_MD_CTX, MdCtxFree> ctx(EVP_MD_CTX_new());
  if (!pkey || !ctx ||
      EVP_DigestVerifyInit(ctx.get(), nullptr, nullptr, nullptr, pkey.get()) != 1) {
    ERR_clear_error();
    return make_error("libcrypto cannot verify Ed25519 signatures");
  }
  const int r = EVP_DigestVerify(ctx.get(), sig, 64, bytes, data.size());
  ERR_clear_error();  // a refused signature leaves its reason queued: not ours to report
  return r == 1;
}

Result<std::array<uint8_t, 64>> blake2b512(std::string_view data) {
  std::array<uint8_t, 64> digest{};
  unsigned n = 0;
  if (EVP_Digest(data.data(), data.size(), digest.data(), &n, EVP_blake2b512(), nullptr) != 1 ||
      n != digest.size()) {
    ERR_clear_error();
    return make_error("libcrypto cannot compute BLAKE2b-512");
  }
  return digest;
}

struct Signature {
  bool prehashed = false;
  std::array<uint8_t, 8> id{};
  std::array<uint8_t, 64> sig{};
  std::string_view trusted_comment;
  std::array<uint8_t, 64> global_sig{};
};

Result<Signature> parse_signature(std::string_view text, const std::string& source) {
  constexpr const char* kWhat = "a minisign signature file";
  Result<std::vector<std::string_view>> lines = split_lines(text, source, 4, kWhat);
  if (!lines) return make_error(lines.error());
  const std::vector<std::string_view>& l = *lines;
  if (!l[0].starts_with(kUntrustedPrefix)) {
    return make_error(source + ": line 1: expected 'untrusted comment: ...' as in " + kWhat +
                      ", found " + quote(l[0]));
  }
  Result<std::vector<uint8_t>> sig =
      decode_line(l[1], source, 2, 74, "74 bytes: algorithm, key ID and Ed25519 signature");
  if (!sig) return make_error(sig.error());
  Signature s;
  const std::string_view alg(reinterpret_cast<const char*>(sig->data()), 2);
  if (alg == "ED") {
    s.prehashed = true;
  } else if (alg != "Ed") {
    return make_error(source + ": line 2: unknown signature algorithm " + quote(alg) +
                      "; expected 'ED' (BLAKE2b-512 prehashed) or 'Ed' (legacy)");
  }
  std::copy_n(sig->begin() + 2, 8, s.id.begin());
  std::copy_n(sig->begin() + 10, 64, s.sig.begin());
  if (!l[2].starts_with(kTrustedPrefix)) {
    return make_error(source + ": line 3: expected 'trusted comment: ...', found " + quote(l[2]));
  }
  s.trusted_comment = l[2].substr(kTrustedPrefix.size());
  Result<std::vector<uint8_t>> global =
      decode_line(l[3], source, 4, 64, "64 bytes: the trusted comment's Ed25519 signature");
  if (!global) return make_error(global.error());
  std::copy_n(global->begin(), 64, s.global_sig.begin());
  return s;
}

// Checks `s` against one key whose id matches: the message, then the comment.
Result<MinisignVerified> verify_with(std::string_view message, const Signature& s,
                                     const std::string& source, const MinisignKey& key) {
  const std::string id = minisign_key_id_hex(key.id);
  Result<bool> ok = false;
  if (s.prehashed) {
    Result<std::array<uint8_t, 64>> digest = blake2b512(message);
    if (!digest) return make_error(source + ": " + digest.error());
    ok = ed25519_verify(key.key, s.sig.data(),
                        std::string_view(reinterpret_cast<const char*>(digest->data()), 64));
  } else {
    ok = ed25519_verify(key.key, s.sig.data(), message);
  }
  if (!ok) return make_error(source + ": " + ok.error());
  if (!*ok) {
    return make_error(source + ": signature by key ID " + id + " (" + key.source +
                      ") does not match the signed data: it was changed, or signed by "
                      "another key");
  }
  // The trusted comment is signed together with the signature it travels
  // with, so it cannot be moved to another signed file.
  std::string global(reinterpret_cast<const char*>(s.sig.data()), s.sig.size());
  global.append(s.trusted_comment);
  ok = ed25519_verify(key.key, s.global_sig.data(), global);
  if (!ok) return make_error(source + ": " + ok.error());
  if (!*ok) {
    return make_error(source + ": line 4: the trusted comment's signature by key ID " + id + " (" +
                      key.source + ") does not verify: the trusted comment was changed");
  }
  return MinisignVerified{id, std::string(s.trusted_comment), key.source, s.prehashed};
}

}  // namespace

std::string minisign_key_id_hex(const std::array<uint8_t, 8>& id) {
  static const char* digits = "0123456789ABCDEF";
  std::string hex;
  for (size_t i = id.size(); i-- > 0;) {
    hex += digits[id[i] >> 4];
    hex += digits[id[i] & 15];
  }
  // As minisign prints it ("%" PRIX64): no leading zeros (1 in 16 ids has one).
  return hex.substr(std::min(hex.find_first_not_of('0'), hex.size() - 1));
}

Result<MinisignKey> parse_minisign_public_key(std::string_view text, const std::string& source) {
  try {
    constexpr const char* kWhat = "a minisign public key file";
    Result<std::vector<std::string_view>> lines = split_lines(text, source, 2, kWhat);
    if (!lines) return make_error(lines.error());
    if (!(*lines)[0].starts_with(kUntrustedPrefix)) {
      return make_error(source + ": line 1: expected 'untrusted comment: ...' as in " + kWhat +
                        ", found " + quote((*lines)[0]));
    }
    Result<std::vector<uint8_t>> bytes =
        decode_line((*lines)[1], source, 2, 42, "42 bytes: 'Ed', key ID and Ed25519 public key");
    if (!bytes) return make_error(bytes.error());
    const std::string_view alg(reinterpret_cast<const char*>(bytes->data()), 2);
    if (alg != "Ed") {
      return make_error(source + ": line 2: unknown key algorithm " + quote(alg) +
                        "; expected 'Ed' (Ed25519)");
    }
    MinisignKey key;
    std::copy_n(bytes->begin() + 2, 8, key.id.begin());
    std::copy_n(bytes->begin() + 10, 32, key.key.begin());
    key.source = source;
    return key;
  } catch (const std::exception& e) {  // std::bad_alloc: refuse, do not throw
    return make_error(source + ": " + e.what());
  }
}

Result<MinisignVerified> verify_minisign(std::string_view message, std::string_view signature_text,
                                         const std::string& signature_source,
                                         const std::vector<MinisignKey>& keys) {
  try {
    Result<Signature> s = parse_signature(signature_text, signature_source);
    if (!s) return make_error(s.error());
    // Key ids are not secret and need not be unique: try every key with this
    // one, and report the first one's failure if none verifies.
    std::string first_error;
    for (const MinisignKey& key : keys) {
      if (key.id != s->id) continue;
      Result<MinisignVerified> v = verify_with(message, *s, signature_source, key);
      if (v) return v;
      if (first_error.empty()) first_error = v.error();
    }
    if (!first_error.empty()) return make_error(first_error);
    return make_error(signature_source + ": signed by key ID " + minisign_key_id_hex(s->id) +
                      ", not by any trusted key");
  } catch (const std::exception& e) {
    return make_error(signature_source + ": " + e.what());
  }
}

Result<std::vector<MinisignKey>> load_trusted_keys(const std::string& dir) {
  namespace fs = std::filesystem;
  try {
    std::vector<std::string> paths;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string name = it->path().filename().string();
      if (name.size() > 4 && name.ends_with(".pub")) paths.push_back(it->path().string());
    }
    if (ec) return make_error(dir + ": cannot read the trusted key directory: " + ec.message());
    if (paths.empty()) return make_error(dir + ": no trusted keys (*.pub files) in the directory");
    std::sort(paths.begin(), paths.end());
    std::vector<MinisignKey> keys;
    for (const std::string& path : paths) {
      Result<std::string> text = read_input_file(path, kMaxKeyFileBytes);
      if (!text) return make_error(text.error());
      Result<MinisignKey> key = parse_minisign_public_key(*text, path);
      if (!key) return make_error(key.error());
      keys.push_back(std::move(*key));
    }
    return keys;
  } catch (const std::exception& e) {
    return make_error(dir + ": " + e.what());
  }
}

}  // namespace contego::bundle

namespace contego::bundle {
namespace {

std::string encode_base64(const uint8_t* bytes, size_t n) {
  std::string out(4 * ((n + 2) / 3) + 1, '\0');
  const int len =
      EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), bytes, static_cast<int>(n));
  out.resize(len < 0 ? 0 : static_cast<size_t>(len));
  return out;
}

// `key`'s Ed25519 signature of `data`, or why libcrypto could not make it.
Result<std::array<uint8_t, 64>> ed25519_sign(const MinisignSecretKey& key, std::string_view data) {
  static const unsigned char kEmpty = 0;
  const auto* bytes = data.empty() ? &kEmpty : reinterpret_cast<const unsigned char*>(data.data());
  std::unique_ptr<EVP_PKEY, PkeyFree> pkey(
      EVP_PKEY_new_raw_private_key(EVP_PKEY_ED25519, nullptr, key.seed.data(), key.seed.size()));
  std::unique_ptr<EVP_MD_CTX, MdCtxFree> ctx(EVP_MD_CTX_new());
  std::array<uint8_t, 64> sig{};
  size_t n = sig.size();
  if (!pkey || !ctx || EVP_DigestSignInit(ctx.get(), nullptr, nullptr, nullptr, pkey.get()) != 1 ||
      EVP_DigestSign(ctx.get(), sig.data(), &n, bytes, data.size()) != 1 || n != sig.size()) {
    ERR_clear_error();
    return make_error("libcrypto cannot make Ed25519 signatures");
  }
  return sig;
}

}  // namespace

Result<MinisignSecretKey> parse_minisign_secret_key(std::string_view text,
                                                    const std::string& source) {
  constexpr const char* kWhat = "a minisign secret key file";
  try {
    Result<std::vector<std::string_view>> lines = split_lines(text, source, 2, kWhat);
    if (!lines) return make_error(lines.error());
    if (!(*lines)[0].starts_with(kUntrustedPrefix)) {
      return make_error(source + ": line 1: expected 'untrusted comment: ...' as in " + kWhat);
    }
    Result<std::vector<uint8_t>> b =
        decode_line((*lines)[1], source, 2, 158, "158 bytes: a minisign secret key");
    if (!b) return make_error(b.error());
    const std::string_view alg(reinterpret_cast<const char*>(b->data()), 2);
    const std::string_view kdf(reinterpret_cast<const char*>(b->data() + 2), 2);
    if (alg != "Ed") return make_error(source + ": not an Ed25519 minisign key " + quote(alg));
    if (kdf != std::string_view("\0\0", 2)) {
      return make_error(source +
                        ": the key is encrypted with a password; the monitor signs unattended: "
                        "make its key with `minisign -G -W`");
    }
    MinisignSecretKey key;
    key.source = source;
    constexpr size_t kKeynum = 2 + 2 + 2 + 32 + 8 + 8;
    std::copy_n(b->begin() + kKeynum, 8, key.id.begin());
    std::copy_n(b->begin() + kKeynum + 8, 32, key.seed.begin());
    std::copy_n(b->begin() + kKeynum + 40, 32, key.public_key.begin());
    // The public half must be the seed's: a damaged file never signs.
    std::unique_ptr<EVP_PKEY, PkeyFree> pkey(
        EVP_PKEY_new_raw_private_key(EVP_PKEY_ED25519, nullptr, key.seed.data(), key.seed.size()));
    std::array<uint8_t, 32> derived{};
    size_t n = derived.size();
    if (!pkey || EVP_PKEY_get_raw_public_key(pkey.get(), derived.data(), &n) != 1 ||
        derived != key.public_key) {
      ERR_clear_error();
      return make_error(source + ": damaged: its public half is not its secret half's");
    }
    return key;
  } catch (const std::exception& e) {
    return make_error(source + ": " + e.what());
  }
}

Result<std::string> sign_minisign(std::string_view message, const MinisignSecretKey& key,
                                  std::string_view trusted_comment) {
  if (trusted_comment.find_first_of("\r\n") != std::string_view::npos) {
    return make_error("a trusted comment is one line");
  }
  Result<std::array<uint8_t, 64>> digest = blake2b512(message);
  if (!digest) return make_error(digest.error());
  Result<std::array<uint8_t, 64>> sig = ed25519_sign(
      key, std::string_view(reinterpret_cast<const char*>(digest->data()), digest->size()));
  if (!sig) return make_error(sig.error());
  std::vector<uint8_t> line2 = {'E', 'D'};
  line2.insert(line2.end(), key.id.begin(), key.id.end());
  line2.insert(line2.end(), sig->begin(), sig->end());
  std::string global(reinterpret_cast<const char*>(sig->data()), sig->size());
  global.append(trusted_comment);
  Result<std::array<uint8_t, 64>> global_sig = ed25519_sign(key, global);
  if (!global_sig) return make_error(global_sig.error());
  return std::string(kUntrustedPrefix) + "signature from contego, key ID " +
         minisign_key_id_hex(key.id) + "\n" + encode_base64(line2.data(), line2.size()) + "\n" +
         std::string(kTrustedPrefix) + std::string(trusted_comment) + "\n" +
         encode_base64(global_sig->data(), global_sig->size()) + "\n";
}

}  // namespace contego::bundle
