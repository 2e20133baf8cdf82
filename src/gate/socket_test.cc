#include "gate/socket.h"

#include <unistd.h>

#include <filesystem>
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <thread>

#include "base/test_temp.h"
#include "gate/operator.h"
#include "gate/socket_client.h"

namespace contego::gate {
namespace {

class FramePair : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM, 0, fds), 0); }
  void TearDown() override {
    close(fds[0]);
    if (fds[1] >= 0) close(fds[1]);
  }
  int fds[2] = {-1, -1};
};

// A client may send a job-end and a transfer back to back: one recv brings
// both, and the reader must hand them out one by one.
TEST_F(FramePair, TwoFramesInOneSendComeOutSeparately) {
  std::vector<uint8_t> both = wire::frame(wire::Type::kJobEnd, 7, {});
  const std::vector<uint8_t> payload = {1, 2, 3};
  const auto second = wire::frame(wire::Type::kTransfer, 8, payload);
  both.insert(both.end(), second.begin(), second.end());
  ASSERT_EQ(write(fds[1], both.data(), both.size()), static_cast<ssize_t>(both.size()));
  FrameReader reader(fds[0]);
  wire::Header h;
  std::span<const uint8_t> p;
  ASSERT_EQ(reader.next(&h, &p).kind, FrameStatus::Kind::kFrame);
  EXPECT_EQ(h.type, static_cast<uint8_t>(wire::Type::kJobEnd));
  EXPECT_EQ(h.seq, 7u);
  EXPECT_TRUE(p.empty());
  ASSERT_EQ(reader.next(&h, &p).kind, FrameStatus::Kind::kFrame);
  EXPECT_EQ(h.type, static_cast<uint8_t>(wire::Type::kTransfer));
  EXPECT_EQ(h.seq, 8u);
  EXPECT_EQ(std::vector<uint8_t>(p.begin(), p.end()), payload);
  close(fds[1]);
  fds[1] = -1;
  EXPECT_EQ(reader.next(&h, &p).kind, FrameStatus::Kind::kClosed);
}

// The largest frame (42 messages of 8192 bytes) is bigger than the reader's
// first buffer and arrives in many pieces.
TEST_F(FramePair, AFrameLargerThanTheBufferArrivesWhole) {
  std::vector<uint8_t> big(wire::kMaxPayload);
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<uint8_t>(i * 7);
  std::thread writer([&] {
    EXPECT_TRUE(send_frame(fds[1], wire::Type::kTransfer, 1, big));
    EXPECT_TRUE(send_frame(fds[1], wire::Type::kReply, 2, std::vector<uint8_t>{9}));
  });
  FrameReader reader(fds[0]);
  wire::Header h;
  std::span<const uint8_t> p;
  ASSERT_EQ(reader.next(&h, &p).kind, FrameStatus::Kind::kFrame);
  EXPECT_EQ(h.length, wire::kMaxPayload);
  EXPECT_TRUE(std::equal(p.begin(), p.end(), big.begin(), big.end()));
  ASSERT_EQ(reader.next(&h, &p).kind, FrameStatus::Kind::kFrame);
  EXPECT_EQ(h.seq, 2u);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0], 9);
  writer.join();
}

TEST_F(FramePair, AnOversizedHeaderIsRefusedAndATruncatedFrameReported) {
  uint8_t raw[wire::kHeaderSize];
  wire::encode_header(wire::Type::kTransfer, 1, wire::kMaxPayload + 1, raw);
  ASSERT_EQ(write(fds[1], raw, sizeof raw), static_cast<ssize_t>(sizeof raw));
  FrameReader reader(fds[0]);
  wire::Header h;
  std::span<const uint8_t> p;
  const FrameStatus got = reader.next(&h, &p);
  EXPECT_EQ(got.kind, FrameStatus::Kind::kBroken);
  EXPECT_NE(got.why.find("exceeds"), std::string::npos);

  int other[2];
  ASSERT_EQ(socketpair(AF_UNIX, SOCK_STREAM, 0, other), 0);
  wire::encode_header(wire::Type::kTransfer, 1, 10, raw);
  ASSERT_EQ(write(other[1], raw, sizeof raw), static_cast<ssize_t>(sizeof raw));
  ASSERT_EQ(write(other[1], raw, 4), 4);  // 4 of the 10 payload bytes
  close(other[1]);
  FrameReader cut(other[0]);
  const FrameStatus truncated = cut.next(&h, &p);
  EXPECT_EQ(truncated.kind, FrameStatus::Kind::kBroken);
  EXPECT_EQ(truncated.why, "truncated payload");
  close(other[0]);
}

// The monitor refuses a peer at accept (seq 0) and closes at once, maybe
// before the client's request arrived: a send that then fails (EPIPE) must
// not hide the reason, which is already in the client's receive queue.
TEST(RefusalAtAccept, ReachesTheClientWithItsReasonWhateverTheOrder) {
  std::string dir;
  ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("gate-refusal", &dir));
  const std::string path = dir + "/m.sock";
  const int listener = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(listener, 8), 0);
  constexpr int kRounds = 100;
  std::thread server([listener] {
    for (int i = 0; i < 2 * kRounds; ++i) {
      const int fd = accept(listener, nullptr, nullptr);
      if (fd < 0) return;
      send_frame(fd, wire::Type::kError, 0, wire::encode_error({EACCES, "peer uid not allowed"}));
      close(fd);
    }
  });
  int told = 0;
  for (int i = 0; i < kRounds; ++i) {
    auto c = SocketClient::connect(path, "gripper", std::nullopt);
    told += !c.ok() && c.error().find("peer uid not allowed") != std::string::npos;
    auto r = request_reset(path, "arm");
    told += !r.ok() && r.error().find("peer uid not allowed") != std::string::npos;
  }
  server.join();
  close(listener);
  std::filesystem::remove_all(dir);
  EXPECT_EQ(told, 2 * kRounds);
}

}  // namespace
}  // namespace contego::gate
