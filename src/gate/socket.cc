#include "gate/socket.h"

#include <errno.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>

#include "base/unique_fd.h"

namespace contego::gate {

Result<base::UniqueFd> connect_to_monitor(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return make_error("socket path too long: " + path);
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  base::UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (!fd.valid()) return make_error(std::string("socket: ") + std::strerror(errno));
  if (::connect(fd.get(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    return make_error("cannot reach the monitor at " + path + ": " + std::strerror(errno));
  }
  return fd;
}

bool send_frame(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload) {
  // Header on the stack, payload where it is: one sendmsg, no copy, no allocation.
  uint8_t header[wire::kHeaderSize];
  wire::encode_header(type, seq, static_cast<uint32_t>(payload.size()), header);
  iovec iov[2] = {{header, sizeof header}, {const_cast<uint8_t*>(payload.data()), payload.size()}};
  msghdr msg{};
  msg.msg_iov = iov;
  msg.msg_iovlen = payload.empty() ? 1 : 2;
  size_t left = sizeof header + payload.size();
  while (left > 0) {
    const ssize_t n = ::sendmsg(fd, &msg, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    left -= static_cast<size_t>(n);
    // A partial send (a large frame, a full socket buffer): skip what went out.
    size_t sent = static_cast<size_t>(n);
    while (sent > 0 && msg.msg_iovlen > 0) {
      const size_t take = std::min(sent, msg.msg_iov[0].iov_len);
      msg.msg_iov[0].iov_base = static_cast<uint8_t*>(msg.msg_iov[0].iov_base) + take;
      msg.msg_iov[0].iov_len -= take;
      sent -= take;
      if (msg.msg_iov[0].iov_len == 0) {
        ++msg.msg_iov;
        --msg.msg_iovlen;
      }
    }
  }
  return true;
}

FrameReader::FrameReader(int fd) : fd_(fd), buf_(kInitialCapacity) {}

FrameStatus FrameReader::next(wire::Header* header, std::span<const uint8_t>* payload) {
  // Drop the frame handed out last time; keep whatever followed it.
  start_ += consumed_;
  consumed_ = 0;
  if (start_ == end_) start_ = end_ = 0;
  bool have_header = false;
  for (;;) {
    const size_t avail = end_ - start_;
    if (!have_header && avail >= wire::kHeaderSize) {
      if (Status st = wire::decode_header({buf_.data() + start_, wire::kHeaderSize}, header);
          !st.ok()) {
        return {FrameStatus::Kind::kBroken, st.error()};
      }
      have_header = true;
    }
    if (have_header) {
      const size_t need = wire::kHeaderSize + header->length;
      if (avail >= need) {
        *payload = {buf_.data() + start_ + wire::kHeaderSize, header->length};
        consumed_ = need;
        return {};
      }
      if (buf_.size() - start_ < need) {  // make room: move to the front, grow if needed
        std::memmove(buf_.data(), buf_.data() + start_, avail);
        start_ = 0;
        end_ = avail;
        if (buf_.size() < need) buf_.resize(need);
      }
    } else if (start_ > 0 && buf_.size() - end_ < wire::kHeaderSize) {
      std::memmove(buf_.data(), buf_.data() + start_, avail);
      start_ = 0;
      end_ = avail;
    }
    // Usually one recv brings the whole frame (header and payload).
    const ssize_t n = ::recv(fd_, buf_.data() + end_, buf_.size() - end_, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0 && avail == 0) return {FrameStatus::Kind::kClosed, "closed"};
    if (n <= 0) {
      return {FrameStatus::Kind::kBroken, have_header ? "truncated payload" : "truncated header"};
    }
    end_ += static_cast<size_t>(n);
  }
}

Status recv_frame(int fd, wire::Header* header, std::vector<uint8_t>* payload) {
  // Unbuffered (reads exactly one frame, never past it): for callers that
  // do not keep a FrameReader. Two recv calls per frame.
  uint8_t raw[wire::kHeaderSize];
  size_t off = 0;
  while (off < sizeof raw) {
    const ssize_t n = ::recv(fd, raw + off, sizeof raw - off, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0 && off == 0) return make_error("closed");
    if (n <= 0) return make_error("truncated header");
    off += static_cast<size_t>(n);
  }
  if (Status st = wire::decode_header(raw, header); !st.ok()) return st;
  payload->resize(header->length);
  off = 0;
  while (off < header->length) {
    const ssize_t n = ::recv(fd, payload->data() + off, header->length - off, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return make_error("truncated payload");
    off += static_cast<size_t>(n);
  }
  return {};
}

}  // namespace contego::gate
