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
      if (std::string why = wire::decode_header({buf_.data() + start_, wire::kHeaderSize}, header);
          !why.empty()) {
        return {FrameStatus::Kind::kBroken, why};
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

std::string recv_frame(int fd, wire::Header* header, std::vector<uint8_t>* payload) {
  // Unbuffered (reads exactly one frame, never past it): for callers that
  // do not keep a FrameReader. Two recv calls per frame.
  uint8_t raw[wire::kHeaderSize];
  size_t off = 0;
  while (off < sizeof raw) {
    const ssize_t n = ::recv(fd, raw + off, sizeof raw - off, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0 && off == 0) return "closed";
    if (n <= 0) return "truncated header";
    off += static_cast<size_t>(n);
  }
  if (std::string why = wire::decode_header(raw, header); !why.empty()) return why;
  payload->resize(header->length);
  off = 0;
  while (off < header->length) {
    const ssize_t n = ::recv(fd, payload->data() + off, header->length - off, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return "truncated payload";
    off += static_cast<size_t>(n);
  }
  return {};
}

Result<std::unique_ptr<SocketClient>> SocketClient::connect(const std::string& path,
                                                            const std::string& task,
                                                            std::optional<SpinPolicy> channel,
                                                            const wire::Vouch& vouch) {
  auto fd = connect_to_monitor(path);
  if (!fd) return make_error(fd.error());
  std::unique_ptr<SocketClient> c(new SocketClient(fd->release()));
  SocketClient* const client = c.get();
  base::MutexLock lock(client->mu_);  // not shared yet: for exchange()'s REQUIRES
  wire::Header h;
  std::span<const uint8_t> answer;
  if (!client->exchange(wire::Type::kHello, wire::encode_hello(task, vouch), &h, &answer)) {
    return make_error("the monitor at " + path + " closed the connection during hello");
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kError)) {
    wire::ErrorMsg e;
    (void)wire::decode_error(answer, &e);
    return make_error("the monitor refused task '" + task + "': " + e.reason);
  }
  wire::HelloOk ok;
  if (h.type != static_cast<uint8_t>(wire::Type::kHelloOk) ||
      !wire::decode_hello_ok(answer, &ok).empty()) {
    return make_error("unexpected answer to hello from " + path);
  }
  c->task_id_ = ok.task;
  c->task_priority_ = ok.priority;
  if (channel) client->open_channel(*channel);
  return c;
}

SocketClient::~SocketClient() { ::close(fd_); }

void SocketClient::open_channel(SpinPolicy policy) {
  if (!send_frame(fd_, wire::Type::kChannel, ++seq_, {})) {
    broken_ = true;
    return;
  }
  wire::Header h;
  std::vector<uint8_t> answer;
  int received = -1;
  const std::string why = recv_frame_with_fd(fd_, &h, &answer, &received);
  base::UniqueFd memfd(received);
  if (!why.empty() || h.seq != seq_) {
    broken_ = true;
    return;
  }
  if (h.type != static_cast<uint8_t>(wire::Type::kChannelOk) || !memfd.valid()) {
    return;  // refused: keep using the socket
  }
  if (auto c = Channel::attach(memfd.release(), fd_, policy)) {
    channel_ = std::move(*c);
  } else {
    // The monitor switched this connection to the channel; without it the
    // connection cannot go on.
    broken_ = true;
  }
}

bool SocketClient::exchange(wire::Type type, std::span<const uint8_t> payload, wire::Header* h,
                            std::span<const uint8_t>* answer) {
  if (broken_) return false;
  if (channel_) {
    uint32_t seq = 0;
    if (!channel_->post(type, payload, &seq) || !channel_->await_reply(seq, &h->type, answer)) {
      broken_ = true;  // fail closed from now on
      return false;
    }
    h->seq = seq;
    h->length = static_cast<uint32_t>(answer->size());
    return true;
  }
  // A refusal at accept (seq 0) may be queued before the request could be
  // sent (EPIPE): read it anyway, so that its reason reaches the caller.
  const uint32_t seq = ++seq_;
  const bool sent = send_frame(fd_, type, seq, payload);
  const bool got = reader_.next(h, answer).ok();
  const bool refused = got && h->seq == 0 && h->type == static_cast<uint8_t>(wire::Type::kError);
  if (!got || refused || !sent || h->seq != seq) broken_ = true;  // fail closed from now on
  return refused || (got && sent && h->seq == seq);
}

bool SocketClient::wait_closed(int timeout_ms) const {
  pollfd p{fd_, POLLRDHUP, 0};
  const int n = poll(&p, 1, timeout_ms);
  return n > 0 && (p.revents & (POLLRDHUP | POLLHUP | POLLERR | POLLNVAL)) != 0;
}

TransferReply SocketClient::transfer(uint16_t /*task: bound by hello*/, const Transfer& t) {
  base::MutexLock lock(mu_);
  TransferReply reply;
  wire::Header h;
  std::span<const uint8_t> answer;
  wire::encode_transfer(t, &out_);
  if (!exchange(wire::Type::kTransfer, out_, &h, &answer)) {
    reply.err = EIO;  // monitor unreachable: the actuation fails
    return reply;
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kReply) &&
      wire::decode_reply(answer, &reply).empty()) {
    return reply;
  }
  wire::ErrorMsg e;
  reply = TransferReply{};
  reply.err = h.type == static_cast<uint8_t>(wire::Type::kError) &&
                      wire::decode_error(answer, &e).empty() && e.err != 0
                  ? e.err
                  : EIO;
  return reply;
}

void SocketClient::job_boundary(uint16_t /*task*/) {
  base::MutexLock lock(mu_);
  if (broken_) return;
  uint32_t seq = 0;
  // Through the channel: posted, not awaited (the next post waits for the slot).
  const bool sent = channel_ ? channel_->post(wire::Type::kJobEnd, {}, &seq)
                             : send_frame(fd_, wire::Type::kJobEnd, ++seq_, {});
  if (!sent) broken_ = true;
}

void SocketClient::task_exited(uint16_t /*task*/) {
  // The monitor sees the connection close and drives the safe state itself.
  base::MutexLock lock(mu_);
  ::shutdown(fd_, SHUT_RDWR);
  if (channel_) channel_->hang_up();  // wake the monitor's thread to see it now
  broken_ = true;
}

wire::BusInfo SocketClient::bus_info(uint8_t bus) {
  base::MutexLock lock(mu_);
  auto it = buses_.find(bus);
  if (it != buses_.end()) return it->second;
  wire::Header h;
  std::span<const uint8_t> answer;
  wire::BusInfo info;
  const uint8_t request[1] = {bus};
  if (exchange(wire::Type::kBusInfo, request, &h, &answer) &&
      h.type == static_cast<uint8_t>(wire::Type::kBusInfoOk) &&
      wire::decode_bus_info(answer, &info).empty()) {
    buses_[bus] = info;
  }
  return info;
}

std::string SocketClient::revouch(pid_t pid, const std::string& task) {
  // The path is for the record: the monitor reads the process's executable itself.
  char exe[4096] = {};
  const std::string link = "/proc/" + std::to_string(pid) + "/exe";
  const ssize_t n = readlink(link.c_str(), exe, sizeof exe - 1);
  const std::string path = n > 0 ? std::string(exe, static_cast<size_t>(n)) : "/";
  base::MutexLock lock(mu_);
  wire::Header h;
  std::span<const uint8_t> answer;
  const std::vector<uint8_t> request =
      wire::encode_hello(task, {static_cast<uint32_t>(pid), path[0] == '/' ? path : "/"});
  if (!exchange(wire::Type::kRevouch, request, &h, &answer)) {
    return "the monitor cannot be asked (connection lost)";
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kRevouchOk)) return {};
  wire::ErrorMsg e;
  if (h.type == static_cast<uint8_t>(wire::Type::kError) &&
      wire::decode_error(answer, &e).empty()) {
    return e.reason;
  }
  return "unexpected answer to a re-vouch";
}

bool SocketClient::has_bus(uint8_t bus) { return bus_info(bus).present; }
uint64_t SocketClient::funcs(uint8_t bus) { return bus_info(bus).funcs; }

}  // namespace contego::gate
