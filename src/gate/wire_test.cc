#include "gate/wire.h"

#include <gtest/gtest.h>

namespace contego::gate::wire {
namespace {

TEST(Wire, TransferRoundTrip) {
  Transfer t;
  t.bus = 1;
  Message w;
  w.addr = 0x40;
  w.len = 2;
  w.data = {0xFE, 0x79};
  Message r;
  r.addr = 0x40;
  r.flags = kMsgRead;
  r.len = 3;
  t.messages = {w, r};
  Transfer back;
  ASSERT_TRUE(decode_transfer(encode_transfer(t), &back).ok());
  ASSERT_EQ(back.messages.size(), 2u);
  EXPECT_EQ(back.messages[0].data, w.data);
  EXPECT_TRUE(back.messages[1].is_read());
  EXPECT_EQ(back.messages[1].len, 3);
}

TEST(Wire, TruncatedAndTrailingTransfersAreRefused) {
  Transfer t;
  Message w;
  w.addr = 0x08;
  w.len = 5;
  w.data = {1, 0x77, 0, 0, 0};
  t.messages = {w};
  auto bytes = encode_transfer(t);
  Transfer back;
  auto cut = bytes;
  cut.pop_back();
  EXPECT_EQ(decode_transfer(cut, &back).error(), "truncated message data");
  auto extra = bytes;
  extra.push_back(0);
  EXPECT_EQ(decode_transfer(extra, &back).error(), "trailing bytes after the transfer");
}

// The descriptor's own I2C_RETRIES/I2C_TIMEOUT ride as flag bit 3 and two
// u32 after the messages; a transfer without them is encoded as before.
TEST(Wire, ADescriptorsOwnTimingRidesAfterTheMessages) {
  Transfer t;
  t.bus = 1;
  Message w;
  w.addr = 0x40;
  w.len = 2;
  w.data = {0x06, 0x01};
  t.messages = {w};
  const auto plain = encode_transfer(t);
  EXPECT_EQ(plain[1], 0);  // no flag: what a monitor before the flag reads
  t.timing = {true, 3, 7};
  const auto timed = encode_transfer(t);
  ASSERT_EQ(timed.size(), plain.size() + 8);
  EXPECT_EQ(timed[1], kTransferOwnTiming);
  EXPECT_EQ(std::vector<uint8_t>(timed.end() - 8, timed.end()),
            std::vector<uint8_t>({3, 0, 0, 0, 7, 0, 0, 0}));
  Transfer back;
  ASSERT_TRUE(decode_transfer(timed, &back).ok());
  EXPECT_TRUE(back.timing.own);
  EXPECT_EQ(back.timing.retries, 3u);
  EXPECT_EQ(back.timing.timeout_10ms, 7u);
  EXPECT_EQ(back.messages[0].data, w.data);
  // The same Transfer decoded again from a frame without them: none kept.
  ASSERT_TRUE(decode_transfer(plain, &back).ok());
  EXPECT_FALSE(back.timing.own);
  EXPECT_EQ(back.timing.retries, 0u);
  auto cut = timed;
  cut.pop_back();
  EXPECT_EQ(decode_transfer(cut, &back).error(), "truncated I2C_RETRIES and I2C_TIMEOUT");
  auto beyond = timed;
  beyond[beyond.size() - 1] = 0x10;  // a timeout above INT_MAX / 10
  EXPECT_FALSE(decode_transfer(beyond, &back).ok());
  auto unknown = plain;
  unknown[1] = 0x10;
  EXPECT_EQ(decode_transfer(unknown, &back).error(), "unknown transfer flags");
}

TEST(Wire, HeaderRefusesOversizeBadMagicAndUnknownTypes) {
  auto f = frame(Type::kTransfer, 7, {});
  Header h;
  EXPECT_TRUE(decode_header({f.data(), kHeaderSize}, &h).ok());
  EXPECT_EQ(h.seq, 7u);
  auto big = f;
  big[8] = 0xFF;
  big[9] = 0xFF;
  big[10] = 0xFF;
  EXPECT_NE(decode_header({big.data(), kHeaderSize}, &h).error().find("exceeds"),
            std::string::npos);
  auto magic = f;
  magic[0] = 0;
  EXPECT_EQ(decode_header({magic.data(), kHeaderSize}, &h).error(), "bad magic");
  auto type = f;
  type[3] = 0x42;
  EXPECT_NE(decode_header({type.data(), kHeaderSize}, &h).error().find("unknown message type"),
            std::string::npos);
  auto version = f;
  version[2] = 2;
  EXPECT_NE(decode_header({version.data(), kHeaderSize}, &h).error().find("version"),
            std::string::npos);
}

TEST(Wire, ReplyHelloAndErrorRoundTrip) {
  TransferReply r;
  r.err = 0;
  r.reads = {{1, 2, 3}};
  TransferReply rb;
  ASSERT_TRUE(decode_reply(encode_reply(r), &rb).ok());
  EXPECT_EQ(rb.reads, r.reads);
  std::string task;
  ASSERT_TRUE(decode_hello(encode_hello("rover"), &task).ok());
  EXPECT_EQ(task, "rover");
  EXPECT_FALSE(decode_hello(encode_hello(""), &task).ok());
  EXPECT_FALSE(decode_hello(encode_hello(std::string(65, 'x')), &task).ok());
  ErrorMsg e;
  ASSERT_TRUE(decode_error(encode_error({13, "no"}), &e).ok());
  EXPECT_EQ(e.err, 13);
  EXPECT_EQ(e.reason, "no");
}

TEST(Wire, HelloAnswerCarriesTheTaskAndItsPriority) {
  HelloOk ok;
  ASSERT_TRUE(decode_hello_ok(encode_hello_ok({3, 20}), &ok).ok());
  EXPECT_EQ(ok.task, 3);
  EXPECT_EQ(ok.priority, 20);
  const std::vector<uint8_t> id_only = {3, 0};
  EXPECT_FALSE(decode_hello_ok(id_only, &ok).ok());  // the id alone is malformed
}

TEST(Wire, ReloadCarriesABundleAndItsSignature) {
  ReloadRequest r;
  ASSERT_TRUE(decode_reload(encode_reload({"{bundle}", "sig"}), &r).ok());
  EXPECT_EQ(r.bundle, "{bundle}");
  EXPECT_EQ(r.signature, "sig");
  ASSERT_TRUE(decode_reload(encode_reload({"{bundle}", ""}), &r).ok());
  EXPECT_EQ(r.signature, "");
  EXPECT_FALSE(decode_reload(encode_reload({"", "sig"}), &r).ok());  // no bundle
  std::vector<uint8_t> bytes = encode_reload({"{bundle}", "sig"});
  bytes.push_back(0);
  EXPECT_FALSE(decode_reload(bytes, &r).ok());  // trailing bytes
  bytes.resize(bytes.size() - 3);
  EXPECT_FALSE(decode_reload(bytes, &r).ok());  // truncated signature
  const std::vector<uint8_t> huge = {0xFF, 0xFF, 0xFF, 0xFF};
  EXPECT_FALSE(decode_reload(huge, &r).ok());
}

TEST(Wire, GoodbyeCarriesTheWaitStatusAndNothingElse) {
  for (const int32_t status : {0, 1 << 8, 9, -1}) {
    int32_t got = 12345;
    ASSERT_TRUE(decode_goodbye(encode_goodbye(status), &got).ok());
    EXPECT_EQ(got, status);
  }
  auto f = frame(Type::kGoodbye, 1, encode_goodbye(0));
  Header h;
  EXPECT_TRUE(decode_header({f.data(), kHeaderSize}, &h).ok());
  int32_t got = 0;
  const std::vector<uint8_t> short_payload = {0, 0, 0};
  EXPECT_FALSE(decode_goodbye(short_payload, &got).ok());
  const std::vector<uint8_t> long_payload = {0, 0, 0, 0, 0};
  EXPECT_FALSE(decode_goodbye(long_payload, &got).ok());
}

}  // namespace
}  // namespace contego::gate::wire
