// Fuzzes the minisign verifier the daemon runs on signed policy bundles:
// the input is `key file \0 signature file \0 message` (missing parts are
// empty). The key parsed from the first part, if any, and a fixed key (that
// signed the seeds, so mutations get past the parsers) verify the second part
// over the third; the whole input is also tried as a signature file and as a
// key file, and as a checkpoint secret key. An error must name its source;
// an accepted signature's trusted comment must come from the signature file;
// an accepted secret key's signature must verify with its public half.
// Seeds (fuzz/corpus/minisign/): files made by minisign 0.11.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "bundle/minisign.h"

using namespace contego;
using namespace contego::bundle;

namespace {

constexpr std::string_view kFixedKey =
    "untrusted comment: minisign public key 8FAACB0888135CE7\n"
    "RWTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3A\n";

std::string_view next_part(std::string_view* rest) {
  const size_t end = rest->find('\0');
  const std::string_view part = rest->substr(0, end);
  *rest = end == std::string_view::npos ? std::string_view() : rest->substr(end + 1);
  return part;
}

void check_error(const std::string& error, const std::string& source) {
  if (error.compare(0, source.size() + 2, source + ": ") != 0) __builtin_trap();
}

void verify(std::string_view message, std::string_view sig, const std::vector<MinisignKey>& keys) {
  Result<MinisignVerified> v = verify_minisign(message, sig, "fuzz.minisig", keys);
  if (!v) return check_error(v.error(), "fuzz.minisig");
  if (v->key_id_hex.size() != 16 || sig.find(v->trusted_comment) == std::string_view::npos) {
    __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  static const MinisignKey fixed = *parse_minisign_public_key(kFixedKey, "fixed.pub");
  std::vector<MinisignKey> keys = {fixed};

  std::string_view rest = input;
  const std::string_view key_text = next_part(&rest);
  const std::string_view sig_text = next_part(&rest);
  Result<MinisignKey> key = parse_minisign_public_key(key_text, "fuzz.pub");
  if (key) {
    keys.push_back(*key);
  } else {
    check_error(key.error(), "fuzz.pub");
  }
  verify(rest, sig_text, keys);
  verify(rest, input, keys);
  if (Result<MinisignKey> k = parse_minisign_public_key(input, "fuzz.pub"); !k) {
    check_error(k.error(), "fuzz.pub");
  }
  // The whole input as the monitor's checkpoint key: an accepted one signs
  // what its own public half verifies.
  Result<MinisignSecretKey> secret = parse_minisign_secret_key(input, "fuzz.key");
  if (!secret) return check_error(secret.error(), "fuzz.key"), 0;
  MinisignKey pub;
  pub.id = secret->id;
  pub.key = secret->public_key;
  pub.source = "fuzz.key";
  Result<std::string> signature = sign_minisign(rest, *secret, "fuzz");
  if (!signature || !verify_minisign(rest, *signature, "fuzz.minisig", {pub})) __builtin_trap();
  return 0;
}
