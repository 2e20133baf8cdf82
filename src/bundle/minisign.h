// Verifies minisign signatures (Ed25519; https://jedisct1.github.io/minisign/)
// of policy bundles, with OpenSSL's libcrypto, and makes them for the audit
// log's checkpoints (bundles are signed with the `minisign` tool). Every function returns a Result
// whose error names the file (its `source`) and what is wrong with it; none throws.
//
// Files, as minisign writes them (each line ends in LF; CRLF is accepted):
//   public key: `untrusted comment: ...` / base64("Ed" || key id[8] || key[32])
//   signature:  `untrusted comment: ...` / base64(alg[2] || key id[8] || sig[64])
//               `trusted comment: TEXT` / base64(Ed25519(sig[64] || TEXT))
// where alg is "ED" (sig over BLAKE2b-512 of the message, minisign's default)
// or "Ed" (legacy: sig over the message itself, `minisign -S -l`).
#ifndef CONTEGO_BUNDLE_MINISIGN_H_
#define CONTEGO_BUNDLE_MINISIGN_H_

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace contego::bundle {

struct MinisignKey {
  std::array<uint8_t, 8> id{};    // as stored in the file (little-endian)
  std::array<uint8_t, 32> key{};  // Ed25519 public key
  std::string source;             // the file it came from, for messages
};

// A minisign public key file's text (`source` names it in errors).
Result<MinisignKey> parse_minisign_public_key(std::string_view text, const std::string& source);

struct MinisignVerified {
  std::string key_id_hex;       // as minisign prints it: "D2C9A81C854046AF"
  std::string trusted_comment;  // covered by the signature
  std::string key_source;       // the trusted key file that verified it
  bool prehashed = false;       // "ED" (BLAKE2b-512) rather than legacy "Ed"
};

// Verifies `message` against the signature file text `signature_text` (named
// `signature_source` in errors) with whichever of `keys` has its key id.
// Both the message signature and the trusted comment's must verify.
Result<MinisignVerified> verify_minisign(std::string_view message, std::string_view signature_text,
                                         const std::string& signature_source,
                                         const std::vector<MinisignKey>& keys);

// Every `*.pub` file of `dir`, in name order, each parsed. A file that does
// not parse, an unreadable, missing or key-less directory is an error.
Result<std::vector<MinisignKey>> load_trusted_keys(const std::string& dir);

// An unencrypted minisign secret key (`minisign -G -W`): base64("Ed" || kdf
// "\0\0" || "B2" || salt[32] || opslimit[8] || memlimit[8] || key id[8] ||
// seed[32] || public key[32] || checksum[32]) after an untrusted comment.
// An encrypted key (kdf "Sc") is refused with the way to make one; the
// public half must be the seed's.
struct MinisignSecretKey {
  std::array<uint8_t, 8> id{};
  std::array<uint8_t, 32> seed{};
  std::array<uint8_t, 32> public_key{};
  std::string source;
};
Result<MinisignSecretKey> parse_minisign_secret_key(std::string_view text,
                                                    const std::string& source);

// A minisign signature file's text for `message` (prehashed, "ED"), with
// `trusted_comment` (one line) signed beside it: `minisign -Vm` verifies it.
Result<std::string> sign_minisign(std::string_view message, const MinisignSecretKey& key,
                                  std::string_view trusted_comment);

// The key id as minisign prints it: a little-endian uint64 in uppercase hex,
// without leading zeros.
std::string minisign_key_id_hex(const std::array<uint8_t, 8>& id);

}  // namespace contego::bundle

#endif  // CONTEGO_BUNDLE_MINISIGN_H_
