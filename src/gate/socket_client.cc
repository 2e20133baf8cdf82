#include "gate/socket_client.h"

#include <errno.h>
#include <poll.h>
#include <unistd.h>

#include <string>
#include <sys/socket.h>
#include <vector>

namespace contego::gate {

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
      !wire::decode_hello_ok(answer, &ok).ok()) {
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
  const Status st = recv_frame_with_fd(fd_, &h, &answer, &received);
  base::UniqueFd memfd(received);
  if (!st.ok() || h.seq != seq_) {
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
      wire::decode_reply(answer, &reply).ok()) {
    return reply;
  }
  wire::ErrorMsg e;
  reply = TransferReply{};
  reply.err = h.type == static_cast<uint8_t>(wire::Type::kError) &&
                      wire::decode_error(answer, &e).ok() && e.err != 0
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

void SocketClient::goodbye(int32_t wait_status) {
  base::MutexLock lock(mu_);
  wire::Header h;
  std::span<const uint8_t> answer;
  (void)exchange(wire::Type::kGoodbye, wire::encode_goodbye(wait_status), &h, &answer);
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
      wire::decode_bus_info(answer, &info).ok()) {
    buses_[bus] = info;
  }
  return info;
}

Status SocketClient::revouch(pid_t pid, const std::string& task) {
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
    return make_error("the monitor cannot be asked (connection lost)");
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kRevouchOk)) return {};
  wire::ErrorMsg e;
  if (h.type == static_cast<uint8_t>(wire::Type::kError) && wire::decode_error(answer, &e).ok()) {
    return make_error(e.reason);
  }
  return make_error("unexpected answer to a re-vouch");
}

bool SocketClient::has_bus(uint8_t bus) { return bus_info(bus).present; }
uint64_t SocketClient::funcs(uint8_t bus) { return bus_info(bus).funcs; }

}  // namespace contego::gate
