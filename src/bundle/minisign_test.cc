#include "bundle/minisign.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "base/read_file.h"
#include "base/test_temp.h"

namespace contego::bundle {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

// Made once with minisign 0.11 (`minisign -G -W`, then `-S` and `-S -l` of
// kMessage with the trusted comments below), so these tests run without it.
constexpr std::string_view kMessage = "contego policy bundle v1\n";
constexpr std::string_view kPublicKey =
    "untrusted comment: minisign public key 8FAACB0888135CE7\n"
    "RWTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3A\n";
constexpr std::string_view kKeyId = "8FAACB0888135CE7";
constexpr std::string_view kPrehashedSig =
    "untrusted comment: signature from minisign secret key\n"
    "RUTnXBOICMuqj2GAA21sp3oFEyCQvGQG0NiwDJH0/"
    "UwHspU1PCUACZqqwt3tqOaTBcd8pzqOQm8BYK+jcs40cmTX7XIVAhe"
    "p1AE=\n"
    "trusted comment: bundle rover 7\n"
    "eGRU21FG2KOf+l3HsCKwfJ990HC0zr/FHWUpiQTPtMaK100vZs2aBnk/ytYeaBcex/cBiFb9qkGCJMZZEP8oAg==\n";
constexpr std::string_view kLegacySig =
    "untrusted comment: signature from minisign secret key\n"
    "RWTnXBOICMuqjzzp2px84MB9XuBK6ueM7iNzZ5ADIlbX8BtoEAW1PId2x1EU1y6EgLl8micTyAI97riXB1/"
    "W7ZZuGebo4Cb"
    "08wk=\n"
    "trusted comment: legacy bundle rover 7\n"
    "dO0vGLxoyFEDeNhHpkc0K4TrR7bTQByd/sjDbyMc6EwOurMTqN1Py1vuQ8tLoQ4ASXsgZeSh4Zzv1+TVe1PfBw==\n";

std::vector<MinisignKey> fixed_keys() {
  Result<MinisignKey> key = parse_minisign_public_key(kPublicKey, "fixed.pub");
  EXPECT_TRUE(key.ok()) << key.error();
  if (!key) return {};
  return {*key};
}

std::string replace(std::string_view text, std::string_view from, std::string_view to) {
  std::string s(text);
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

// Line `n` (1-based) of `text` replaced by `line`.
std::string with_line(std::string_view text, int n, std::string_view line) {
  std::string s(text);
  size_t start = 0;
  for (int i = 1; i < n; ++i) start = s.find('\n', start) + 1;
  s.replace(start, s.find('\n', start) - start, line);
  return s;
}

TEST(MinisignTest, ParsesPublicKeyAndPrintsItsIdAsMinisignDoes) {
  Result<MinisignKey> key = parse_minisign_public_key(kPublicKey, "fixed.pub");
  ASSERT_TRUE(key.ok()) << key.error();
  EXPECT_EQ(minisign_key_id_hex(key->id), kKeyId);
  EXPECT_EQ(key->source, "fixed.pub");
  // minisign prints "%" PRIX64: an id whose top nibble is 0 has 15 digits
  // (the tool's own key file said "57021C51537B32B" for this one).
  EXPECT_EQ(minisign_key_id_hex({0x2B, 0xB3, 0x37, 0x15, 0xC5, 0x21, 0x70, 0x05}),
            "57021C51537B32B");
  EXPECT_EQ(minisign_key_id_hex({0, 0, 0, 0, 0, 0, 0, 0}), "0");
}

TEST(MinisignTest, VerifiesFixedPrehashedAndLegacySignatures) {
  const std::vector<MinisignKey> keys = fixed_keys();
  Result<MinisignVerified> pre = verify_minisign(kMessage, kPrehashedSig, "b.minisig", keys);
  ASSERT_TRUE(pre.ok()) << pre.error();
  EXPECT_EQ(pre->trusted_comment, "bundle rover 7");
  EXPECT_EQ(pre->key_id_hex, kKeyId);
  EXPECT_EQ(pre->key_source, "fixed.pub");
  EXPECT_TRUE(pre->prehashed);
  Result<MinisignVerified> legacy = verify_minisign(kMessage, kLegacySig, "l.minisig", keys);
  ASSERT_TRUE(legacy.ok()) << legacy.error();
  EXPECT_EQ(legacy->trusted_comment, "legacy bundle rover 7");
  EXPECT_FALSE(legacy->prehashed);
}

TEST(MinisignTest, AcceptsCrlfLineEndings) {
  std::string key, sig;
  for (char c : kPublicKey) key += c == '\n' ? std::string("\r\n") : std::string(1, c);
  for (char c : kPrehashedSig) sig += c == '\n' ? std::string("\r\n") : std::string(1, c);
  Result<MinisignKey> k = parse_minisign_public_key(key, "crlf.pub");
  ASSERT_TRUE(k.ok()) << k.error();
  Result<MinisignVerified> v = verify_minisign(kMessage, sig, "crlf.minisig", {*k});
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->trusted_comment, "bundle rover 7");  // without the CR
}

TEST(MinisignTest, AcceptsMissingFinalNewlineAndTrailingEmptyLines) {
  const std::vector<MinisignKey> keys = fixed_keys();
  std::string sig(kPrehashedSig);
  sig.pop_back();
  EXPECT_TRUE(verify_minisign(kMessage, sig, "s", keys).ok());
  EXPECT_TRUE(verify_minisign(kMessage, std::string(kPrehashedSig) + "\n\n", "s", keys).ok());
}

TEST(MinisignTest, RefusesChangedMessage) {
  const std::vector<MinisignKey> keys = fixed_keys();
  for (std::string_view sig : {kPrehashedSig, kLegacySig}) {
    std::string message(kMessage);
    message[3] ^= 1;
    Result<MinisignVerified> v = verify_minisign(message, sig, "b.minisig", keys);
    ASSERT_FALSE(v.ok());
    EXPECT_EQ(v.error(),
              "b.minisig: signature by key ID 8FAACB0888135CE7 (fixed.pub) does not match the "
              "signed data: it was changed, or signed by another key");
    EXPECT_FALSE(verify_minisign("", sig, "b.minisig", keys).ok());
  }
}

TEST(MinisignTest, RefusesChangedTrustedComment) {
  const std::string sig = replace(kPrehashedSig, "rover 7", "rover 8");
  Result<MinisignVerified> v = verify_minisign(kMessage, sig, "b.minisig", fixed_keys());
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error(),
            "b.minisig: line 4: the trusted comment's signature by key ID 8FAACB0888135CE7 "
            "(fixed.pub) does not verify: the trusted comment was changed");
}

TEST(MinisignTest, RefusesTrustedCommentMovedFromAnotherSignature) {
  // The legacy file's comment and its signature, under the prehashed signature.
  std::string sig = with_line(kPrehashedSig, 3, "trusted comment: legacy bundle rover 7");
  sig = with_line(sig, 4,
                  "dO0vGLxoyFEDeNhHpkc0K4TrR7bTQByd/sjDbyMc6EwOurMTqN1Py1vuQ8tLoQ4ASXsgZeSh4Zzv1+"
                  "TVe1PfBw==");
  Result<MinisignVerified> v = verify_minisign(kMessage, sig, "b.minisig", fixed_keys());
  ASSERT_FALSE(v.ok());
  EXPECT_THAT(v.error(), HasSubstr("the trusted comment was changed"));
}

TEST(MinisignTest, RefusesSignatureByUntrustedKey) {
  std::vector<MinisignKey> keys = fixed_keys();
  keys[0].id[0] ^= 1;
  Result<MinisignVerified> v = verify_minisign(kMessage, kPrehashedSig, "b.minisig", keys);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error(), "b.minisig: signed by key ID 8FAACB0888135CE7, not by any trusted key");
  v = verify_minisign(kMessage, kPrehashedSig, "b.minisig", {});
  ASSERT_FALSE(v.ok());
  EXPECT_THAT(v.error(), HasSubstr("not by any trusted key"));
}

TEST(MinisignTest, TriesEveryKeyWithTheSignaturesId) {
  std::vector<MinisignKey> keys = fixed_keys();
  MinisignKey impostor = keys[0];  // same id, another (here: invalid) key
  impostor.key[5] ^= 0x40;
  impostor.source = "impostor.pub";
  Result<MinisignVerified> v =
      verify_minisign(kMessage, kPrehashedSig, "b.minisig", {impostor, keys[0]});
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->key_source, "fixed.pub");
  v = verify_minisign(kMessage, kPrehashedSig, "b.minisig", {impostor});
  ASSERT_FALSE(v.ok());
  EXPECT_THAT(v.error(), HasSubstr("(impostor.pub) does not match the signed data"));
}

struct Malformed {
  std::string text;
  std::string error;  // the whole message after "<source>: "
};

TEST(MinisignTest, MalformedSignatureFilesNameTheFileAndTheProblem) {
  const std::string sig(kPrehashedSig);
  const std::string good_line2 = sig.substr(sig.find('\n') + 1, 100);
  const std::vector<Malformed> cases = {
      {"", "empty; expected a minisign signature file"},
      {"\n", "1 line(s); expected 4 in a minisign signature file"},
      {sig.substr(0, sig.find("trusted comment: b")),
       "2 line(s); expected 4 in a minisign signature file"},
      {with_line(sig, 1, "comment: x"),
       "line 1: expected 'untrusted comment: ...' as in a minisign signature file, found "
       "'comment: x'"},
      {with_line(sig, 2, "RUTn#BOI"),
       "line 2: invalid base64: character '#' at column 5 (expected 74 bytes: algorithm, key ID "
       "and Ed25519 signature)"},
      {with_line(sig, 2, good_line2.substr(0, 96)),
       "line 2: decodes to 72 bytes; expected 74 (74 bytes: algorithm, key ID and Ed25519 "
       "signature)"},
      {with_line(sig, 2, good_line2.substr(0, 96) + "AAAAAAAA"),
       "line 2: decodes to 78 bytes; expected 74 (74 bytes: algorithm, key ID and Ed25519 "
       "signature)"},
      {with_line(sig, 2, "RUTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3A"),
       "line 2: decodes to 42 bytes; expected 74 (74 bytes: algorithm, key ID and Ed25519 "
       "signature)"},
      {with_line(sig, 2, "QU" + good_line2.substr(2)),  // "AD..."
       "line 2: unknown signature algorithm 'AD'; expected 'ED' (BLAKE2b-512 prehashed) or 'Ed' "
       "(legacy)"},
      {with_line(sig, 2, good_line2.substr(0, 98) + "F="),
       "line 2: invalid base64: non-zero bits in the padding (expected 74 bytes: algorithm, key "
       "ID and Ed25519 signature)"},
      {with_line(sig, 2, good_line2 + " "),
       "line 2: invalid base64: character ' ' at column 101 (expected 74 bytes: algorithm, key ID "
       "and Ed25519 signature)"},
      {with_line(sig, 2, ""),
       "line 2: invalid base64: empty line (expected 74 bytes: algorithm, key ID and Ed25519 "
       "signature)"},
      {with_line(sig, 3, "trusted comment:x"),
       "line 3: expected 'trusted comment: ...', found 'trusted comment:x'"},
      {with_line(sig, 4, "eGRU"),
       "line 4: decodes to 3 bytes; expected 64 (64 bytes: the trusted comment's Ed25519 "
       "signature)"},
      {with_line(sig, 4, "eGR="),
       "line 4: invalid base64: non-zero bits in the padding (expected 64 bytes: the trusted "
       "comment's Ed25519 signature)"},
      {with_line(sig, 4, "eG=U"),
       "line 4: invalid base64: padding '=' before the end, at column 3 (expected 64 bytes: the "
       "trusted "
       "comment's Ed25519 signature)"},
      {with_line(sig, 4, "eGRUx"),
       "line 4: invalid base64: 5 characters, not a multiple of 4 (expected 64 bytes: the trusted "
       "comment's Ed25519 signature)"},
      {sig + "extra\n", "line 5: unexpected text after a minisign signature file: 'extra'"},
      {std::string(kPublicKey), "2 line(s); expected 4 in a minisign signature file"},
      {with_line(sig, 1, std::string("untrusted\0\xff", 11)),
       "line 1: expected 'untrusted comment: ...' as in a minisign signature file, found "
       "'untrusted\\x00\\xff'"},
  };
  const std::vector<MinisignKey> keys = fixed_keys();
  for (const Malformed& c : cases) {
    Result<MinisignVerified> v = verify_minisign(kMessage, c.text, "bad.minisig", keys);
    ASSERT_FALSE(v.ok()) << c.text;
    EXPECT_EQ(v.error(), "bad.minisig: " + c.error) << c.text;
  }
}

TEST(MinisignTest, MalformedPublicKeyFilesNameTheFileAndTheProblem) {
  const std::string pub(kPublicKey);
  const std::vector<Malformed> cases = {
      {"", "empty; expected a minisign public key file"},
      {"untrusted comment: x\n", "1 line(s); expected 2 in a minisign public key file"},
      {with_line(pub, 1, "RWTn"),
       "line 1: expected 'untrusted comment: ...' as in a minisign public key file, found 'RWTn'"},
      {with_line(pub, 2, "RWTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3"),
       "line 2: invalid base64: 55 characters, not a multiple of 4 (expected 42 bytes: 'Ed', key "
       "ID and Ed25519 public key)"},
      {with_line(pub, 2, "RWTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3AAAAA"),
       "line 2: decodes to 45 bytes; expected 42 (42 bytes: 'Ed', key ID and Ed25519 public "
       "key)"},
      {with_line(pub, 2, "RUTnXBOICMuqj27fdCAh+mZn2/BRViJNlae4SYS5l+3lNRi+wd6J6I3A"),
       "line 2: unknown key algorithm 'ED'; expected 'Ed' (Ed25519)"},
      {pub + "RWTn\n", "line 3: unexpected text after a minisign public key file: 'RWTn'"},
      {std::string(kPrehashedSig),
       "line 3: unexpected text after a minisign public key file: 'trusted comment: bundle rover "
       "7'"},
  };
  for (const Malformed& c : cases) {
    Result<MinisignKey> k = parse_minisign_public_key(c.text, "bad.pub");
    ASSERT_FALSE(k.ok()) << c.text;
    EXPECT_EQ(k.error(), "bad.pub: " + c.error) << c.text;
  }
}

TEST(MinisignTest, QuotesAtMostFortyCharactersOfInput) {
  Result<MinisignKey> k = parse_minisign_public_key(std::string(5000, 'x') + "\nRWTn\n", "k.pub");
  ASSERT_FALSE(k.ok());
  EXPECT_LT(k.error().size(), 200u) << k.error();
  EXPECT_THAT(k.error(), HasSubstr("'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx...'"));
}

void write_file(const std::string& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

TEST(MinisignTest, LoadsTrustedKeysInNameOrder) {
  std::string dir;
  ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("minisign-keys", &dir));
  Result<std::vector<MinisignKey>> keys = load_trusted_keys(dir);
  ASSERT_FALSE(keys.ok());
  EXPECT_EQ(keys.error(), dir + ": no trusted keys (*.pub files) in the directory");
  ASSERT_NO_FATAL_FAILURE(write_file(dir + "/b.pub", kPublicKey));
  ASSERT_NO_FATAL_FAILURE(write_file(dir + "/a.pub", kPublicKey));
  ASSERT_NO_FATAL_FAILURE(write_file(dir + "/notes.txt", "not a key"));
  ASSERT_NO_FATAL_FAILURE(write_file(dir + "/.pub", "not a key either"));
  keys = load_trusted_keys(dir);
  ASSERT_TRUE(keys.ok()) << keys.error();
  ASSERT_EQ(keys->size(), 2u);
  EXPECT_EQ((*keys)[0].source, dir + "/a.pub");
  EXPECT_EQ((*keys)[1].source, dir + "/b.pub");
  Result<MinisignVerified> v = verify_minisign(kMessage, kPrehashedSig, "s", *keys);
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->key_source, dir + "/a.pub");

  ASSERT_NO_FATAL_FAILURE(write_file(dir + "/c.pub", "untrusted comment: x\nRWT!\n"));
  keys = load_trusted_keys(dir);
  ASSERT_FALSE(keys.ok());
  EXPECT_THAT(keys.error(), StartsWith(dir + "/c.pub: line 2: invalid base64"));
  std::filesystem::remove(dir + "/c.pub");
  std::filesystem::create_directory(dir + "/d.pub");
  keys = load_trusted_keys(dir);
  ASSERT_FALSE(keys.ok());
  EXPECT_EQ(keys.error(), dir + "/d.pub: is a directory; expected a regular file");
  std::filesystem::remove_all(dir);

  keys = load_trusted_keys(dir);
  ASSERT_FALSE(keys.ok());
  EXPECT_EQ(keys.error(),
            dir + ": cannot read the trusted key directory: No such file or directory");
}

// --- Round trips through the real tool ---

std::string find_on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    const std::string candidate = dirs.substr(start, end - start) + "/" + name;
    if (end > start && access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

// Runs `argv` in `dir` with its output discarded; its exit status.
int run(const std::string& dir, std::vector<std::string> argv) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = open("/dev/null", O_RDWR);
    if (null < 0 || chdir(dir.c_str()) != 0) _exit(126);
    dup2(null, 0);
    dup2(null, 1);
    dup2(null, 2);
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read_text(const std::string& path) {
  Result<std::string> text = read_input_file(path);
  EXPECT_TRUE(text.ok()) << text.error();
  return text ? *text : std::string();
}

class MinisignToolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    tool_ = find_on_path("minisign");
    if (tool_.empty()) GTEST_SKIP() << "minisign is not on PATH (tools/bootstrap.sh installs it)";
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("minisign-tool", &dir_));
    ASSERT_EQ(run(dir_, {tool_, "-G", "-W", "-p", "k.pub", "-s", "k.key"}), 0);
    Result<MinisignKey> key = parse_minisign_public_key(read_text(dir_ + "/k.pub"), "k.pub");
    ASSERT_TRUE(key.ok()) << key.error();
    keys_ = {*key};
  }
  void TearDown() override {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  // Signs `message` (as file m) with the trusted comment `comment`; the
  // signature file's text.
  std::string sign(std::string_view message, const std::string& comment, bool legacy) {
    write_file(dir_ + "/m", message);
    std::vector<std::string> argv = {tool_, "-S", "-s", "k.key", "-m", "m", "-t", comment};
    if (legacy) argv.push_back("-l");
    EXPECT_EQ(run(dir_, argv), 0);
    return read_text(dir_ + "/m.minisig");
  }

  std::string tool_, dir_;
  std::vector<MinisignKey> keys_;
};

TEST_F(MinisignToolTest, RoundTripsPrehashedAndLegacySignatures) {
  const std::string message = "policy bundle\n\x01\x02\xff";
  for (bool legacy : {false, true}) {
    SCOPED_TRACE(legacy ? "legacy" : "prehashed");
    const std::string sig = sign(message, "rover bundle 42", legacy);
    Result<MinisignVerified> v = verify_minisign(message, sig, "m.minisig", keys_);
    ASSERT_TRUE(v.ok()) << v.error();
    EXPECT_EQ(v->trusted_comment, "rover bundle 42");
    EXPECT_EQ(v->prehashed, !legacy);
    EXPECT_EQ(v->key_id_hex, minisign_key_id_hex(keys_[0].id));
    // The id in the key file's comment is the one minisign prints.
    EXPECT_THAT(read_text(dir_ + "/k.pub"), HasSubstr("public key " + v->key_id_hex + "\n"));

    std::string changed = message;
    changed[0] ^= 0x20;
    v = verify_minisign(changed, sig, "m.minisig", keys_);
    ASSERT_FALSE(v.ok());
    EXPECT_THAT(v.error(), HasSubstr("does not match the signed data"));

    v = verify_minisign(message, replace(sig, "bundle 42", "bundle 43"), "m.minisig", keys_);
    ASSERT_FALSE(v.ok());
    EXPECT_THAT(v.error(), HasSubstr("the trusted comment was changed"));
  }
}

TEST_F(MinisignToolTest, SignsEmptyAndLargeMessages) {
  for (const std::string& message : {std::string(), std::string(3 << 20, 'b')}) {
    const std::string sig = sign(message, "size " + std::to_string(message.size()), false);
    Result<MinisignVerified> v = verify_minisign(message, sig, "m.minisig", keys_);
    ASSERT_TRUE(v.ok()) << v.error();
  }
}

TEST_F(MinisignToolTest, RefusesSignatureByAnotherKeyNamingItsId) {
  ASSERT_EQ(run(dir_, {tool_, "-G", "-W", "-p", "other.pub", "-s", "other.key"}), 0);
  Result<MinisignKey> other =
      parse_minisign_public_key(read_text(dir_ + "/other.pub"), "other.pub");
  ASSERT_TRUE(other.ok()) << other.error();
  write_file(dir_ + "/m", "bundle");
  ASSERT_EQ(run(dir_, {tool_, "-S", "-s", "other.key", "-m", "m"}), 0);
  Result<MinisignVerified> v =
      verify_minisign("bundle", read_text(dir_ + "/m.minisig"), "m.minisig", keys_);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.error(), "m.minisig: signed by key ID " + minisign_key_id_hex(other->id) +
                           ", not by any trusted key");
}

// A key made with `minisign -G -W` (unencrypted): the monitor's checkpoint key.
constexpr std::string_view kSecretKey =
    "untrusted comment: minisign encrypted secret key\n"
    "RWQAAEIyAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAXyzufampJEwsZ6cFGDIub"
    "NQ+4vL5eCboHv7FNECNaGnfKfXz0kZ3r4Fk0EhJQLfA6lbD5NtX+"
    "ICT8bwjsBSYR2XeMZqJVP4AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA=\n";
constexpr std::string_view kSecretKeysPublic =
    "untrusted comment: minisign public key\n"
    "RWQBfLO59qakkb4Fk0EhJQLfA6lbD5NtX+ICT8bwjsBSYR2XeMZqJVP4\n";

TEST(MinisignTest, SignsWhatItsVerifierAndMinisignAccept) {
  Result<MinisignSecretKey> key = parse_minisign_secret_key(kSecretKey, "checkpoint.key");
  ASSERT_TRUE(key.ok()) << key.error();
  Result<MinisignKey> pub = parse_minisign_public_key(kSecretKeysPublic, "checkpoint.pub");
  ASSERT_TRUE(pub.ok()) << pub.error();
  EXPECT_EQ(key->id, pub->id);
  Result<std::string> sig = sign_minisign("records 12, last SHA-256 ab", *key, "checkpoint 1");
  ASSERT_TRUE(sig.ok()) << sig.error();
  Result<MinisignVerified> v =
      verify_minisign("records 12, last SHA-256 ab", *sig, "checkpoint", {*pub});
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_TRUE(v->prehashed);
  EXPECT_EQ(v->trusted_comment, "checkpoint 1");
  EXPECT_FALSE(verify_minisign("records 13, last SHA-256 ab", *sig, "checkpoint", {*pub}).ok());
  EXPECT_FALSE(sign_minisign("m", *key, "two\nlines").ok());
}

TEST(MinisignTest, RefusesEncryptedAndDamagedSecretKeys) {
  const std::string encrypted =
      "untrusted comment: "
      "k\nRWRTY0IyAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAXyzufampJEwsZ6cF"
      "GDIubNQ+4vL5eCboHv7FNECNaGnfKfXz0kZ3r4Fk0EhJQLfA6lbD5NtX+"
      "ICT8bwjsBSYR2XeMZqJVP4AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA=\n";
  Result<MinisignSecretKey> e = parse_minisign_secret_key(encrypted, "enc.key");
  ASSERT_FALSE(e.ok());
  EXPECT_THAT(e.error(), HasSubstr("minisign -G -W"));
  const std::string damaged =
      "untrusted comment: "
      "k\nRWQAAEIyAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAXyzufampJEwsZ6cF"
      "GDIubNQ+4vL5eCboHv7FNECNaGnfKfXz0kZ3r4Fk0EhJQLfA6lbD5NtX+"
      "ICT8bwjsBSYR2XeMZqJVP5AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA=\n";
  Result<MinisignSecretKey> d = parse_minisign_secret_key(damaged, "dam.key");
  ASSERT_FALSE(d.ok());
  EXPECT_THAT(d.error(), HasSubstr("damaged"));
  EXPECT_FALSE(parse_minisign_secret_key(kSecretKeysPublic, "pub.key").ok());
}

}  // namespace
}  // namespace contego::bundle
