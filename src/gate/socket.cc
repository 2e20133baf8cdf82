#include "gate/socket.h"

#include <errno.h>
#include <unistd.h>

#include <cstring>
#include <sys/socket.h>
#include <sys/un.h>

namespace contego::gate {

bool send_frame(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload) {
  const std::vector<uint8_t> f = wire::frame(type, seq, payload);
  size_t off = 0;
  while (off < f.size()) {
    const ssize_t n = ::send(fd, f.data() + off, f.size() - off, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    off += static_cast<size_t>(n);
  }
  return true;
}

namespace {
bool read_all(int fd, uint8_t* buf, size_t len, bool* eof) {
  size_t off = 0;
  while (off < len) {
    const ssize_t n = ::recv(fd, buf + off, len - off, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0 && off == 0) *eof = true;
    if (n <= 0) return false;
    off += static_cast<size_t>(n);
  }
  return true;
}
}  // namespace

std::string recv_frame(int fd, wire::Header* header, std::vector<uint8_t>* payload) {
  uint8_t raw[wire::kHeaderSize];
  bool eof = false;
  if (!read_all(fd, raw, sizeof raw, &eof)) return eof ? "closed" : "truncated header";
  if (std::string why = wire::decode_header(raw, header); !why.empty()) return why;
  payload->resize(header->length);
  if (header->length != 0 && !read_all(fd, payload->data(), header->length, &eof)) {
    return "truncated payload";
  }
  return {};
}

Result<std::unique_ptr<SocketClient>> SocketClient::connect(const std::string& path,
                                                            const std::string& task) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return make_error("socket path too long: " + path);
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return make_error(std::string("socket: ") + std::strerror(errno));
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::close(fd);
    return make_error("cannot reach the monitor at " + path + ": " + std::strerror(e));
  }
  std::unique_ptr<SocketClient> c(new SocketClient(fd));
  wire::Header h;
  std::vector<uint8_t> answer;
  if (!c->exchange(wire::Type::kHello, wire::encode_hello(task), &h, &answer)) {
    return make_error("the monitor at " + path + " closed the connection during hello");
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kError)) {
    wire::ErrorMsg e;
    (void)wire::decode_error(answer, &e);
    return make_error("the monitor refused task '" + task + "': " + e.reason);
  }
  if (h.type != static_cast<uint8_t>(wire::Type::kHelloOk) ||
      !wire::decode_u16(answer, &c->task_id_).empty()) {
    return make_error("unexpected answer to hello from " + path);
  }
  return c;
}

SocketClient::~SocketClient() { ::close(fd_); }

bool SocketClient::exchange(wire::Type type, const std::vector<uint8_t>& payload, wire::Header* h,
                            std::vector<uint8_t>* answer) {
  if (broken_) return false;
  const uint32_t seq = ++seq_;
  if (!send_frame(fd_, type, seq, payload) || !recv_frame(fd_, h, answer).empty() ||
      h->seq != seq) {
    broken_ = true;  // fail closed from now on
    return false;
  }
  return true;
}

TransferReply SocketClient::transfer(uint16_t /*task: bound by hello*/, const Transfer& t) {
  std::lock_guard lock(mu_);
  TransferReply reply;
  wire::Header h;
  std::vector<uint8_t> answer;
  if (!exchange(wire::Type::kTransfer, wire::encode_transfer(t), &h, &answer)) {
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
  std::lock_guard lock(mu_);
  if (!broken_ && !send_frame(fd_, wire::Type::kJobEnd, ++seq_, {})) broken_ = true;
}

void SocketClient::task_exited(uint16_t /*task*/) {
  // The monitor sees the connection close and drives the safe state itself.
  std::lock_guard lock(mu_);
  ::shutdown(fd_, SHUT_RDWR);
  broken_ = true;
}

wire::BusInfo SocketClient::bus_info(uint8_t bus) {
  std::lock_guard lock(mu_);
  auto it = buses_.find(bus);
  if (it != buses_.end()) return it->second;
  wire::Header h;
  std::vector<uint8_t> answer;
  wire::BusInfo info;
  if (exchange(wire::Type::kBusInfo, {bus}, &h, &answer) &&
      h.type == static_cast<uint8_t>(wire::Type::kBusInfoOk) &&
      wire::decode_bus_info(answer, &info).empty()) {
    buses_[bus] = info;
  }
  return info;
}

bool SocketClient::has_bus(uint8_t bus) { return bus_info(bus).present; }
uint64_t SocketClient::funcs(uint8_t bus) { return bus_info(bus).funcs; }

}  // namespace contego::gate
