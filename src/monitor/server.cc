#include "monitor/server.h"

#include <errno.h>
#include <unistd.h>

#include <cstring>
#include <fmt/core.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include "base/realtime.h"
#include "gate/channel.h"
#include "gate/socket.h"
#include "gate/wire.h"

namespace contego::monitor {

namespace wire = gate::wire;

Server::Server(Monitor& monitor, AuditLog& audit, std::map<std::string, uint16_t> tasks,
               std::set<uid_t> allowed_uids, gate::SpinPolicy spin, bool realtime)
    : monitor_(monitor),
      audit_(audit),
      tasks_(std::move(tasks)),
      allowed_(std::move(allowed_uids)),
      spin_(spin),
      realtime_(realtime) {}

Server::~Server() {
  stop();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  if (listen_fd_ >= 0) close(listen_fd_);
  if (!path_.empty()) unlink(path_.c_str());
}

Status Server::listen(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return make_error("socket path too long: " + path);
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  listen_fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return make_error(std::string("socket: ") + strerror(errno));
  unlink(path.c_str());
  if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    return make_error("cannot bind " + path + ": " + strerror(errno));
  }
  chmod(path.c_str(), 0660);
  if (::listen(listen_fd_, 16) != 0) return make_error(std::string("listen: ") + strerror(errno));
  path_ = path;
  return {};
}

void Server::serve() {
  while (!stopping_) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR) continue;
      break;  // stop() shut the listening socket down
    }
    ucred cred{};
    socklen_t len = sizeof cred;
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 ||
        allowed_.count(cred.uid) == 0) {
      audit_.event("peer-refused", fmt::format("pid {} uid {}", cred.pid, cred.uid));
      const auto e = wire::encode_error({EACCES, "peer uid not allowed"});
      gate::send_frame(fd, wire::Type::kError, 0, e);
      close(fd);
      continue;
    }
    audit_.event("peer", fmt::format("pid {} uid {}", cred.pid, cred.uid));
    std::lock_guard lock(mu_);
    open_fds_.insert(fd);
    threads_.emplace_back([this, fd] { connection(fd); });
  }
}

void Server::stop() {
  stopping_ = true;
  if (listen_fd_ >= 0) shutdown(listen_fd_, SHUT_RDWR);
  std::lock_guard lock(mu_);
  for (int fd : open_fds_) shutdown(fd, SHUT_RDWR);
}

// One connection's state and its answers, the same whether a message came
// over the socket or through the shared-memory channel.
struct Server::Session {
  bool bound = false;
  uint16_t task = 0;
  gate::Transfer transfer;  // reused: no allocation per exchange once grown
  std::vector<uint8_t> out;
};

// Answers one well-framed message into *out; returns the answer's type, or
// nullopt for a message that has none (job-end over the socket).
std::optional<wire::Type> Server::dispatch(Session& s, uint8_t type,
                                           std::span<const uint8_t> payload, bool channel) {
  auto refuse = [&](int err, const std::string& reason) {
    audit_.event("malformed", reason);
    s.out = wire::encode_error({err, reason});
    return wire::Type::kError;
  };
  switch (static_cast<wire::Type>(type)) {
    case wire::Type::kHello: {
      std::string name;
      if (std::string e = wire::decode_hello(payload, &name); !e.empty()) return refuse(EPROTO, e);
      auto it = tasks_.find(name);
      if (s.bound || it == tasks_.end()) {
        return refuse(EPERM, s.bound ? "already bound to a task" : "no task named '" + name + "'");
      }
      s.bound = true;
      s.task = it->second;
      const uint16_t priority = monitor_.task_priority(s.task);
      if (realtime_ && priority > 0) {
        // This thread checks the task's commands: it runs at the task's priority.
        if (std::string e = make_thread_realtime(priority); !e.empty()) {
          audit_.event("realtime-refused", fmt::format("task {}: SCHED_FIFO {}: {}", s.task,
                                                       fifo_priority(priority), e));
        }
      }
      s.out = wire::encode_hello_ok({s.task, priority});
      return wire::Type::kHelloOk;
    }
    case wire::Type::kTransfer: {
      if (!s.bound) return refuse(EPERM, "transfer before hello");
      if (std::string e = wire::decode_transfer(payload, &s.transfer); !e.empty()) {
        return refuse(EINVAL, e);
      }
      const gate::TransferReply r = monitor_.transfer(s.task, s.transfer);
      wire::encode_reply(r, &s.out);
      return wire::Type::kReply;
    }
    case wire::Type::kJobEnd:
      if (s.bound) monitor_.job_boundary(s.task);
      if (!channel) return std::nullopt;
      s.out.clear();  // the channel's slot needs an answer to be free again
      return wire::Type::kJobEndOk;
    case wire::Type::kBusInfo: {
      if (payload.size() != 1) return refuse(EPROTO, "malformed bus info request");
      wire::BusInfo info{monitor_.has_bus(payload[0]), monitor_.funcs(payload[0])};
      s.out = wire::encode_bus_info(info);
      return wire::Type::kBusInfoOk;
    }
    default:
      return refuse(EPROTO, fmt::format("unexpected message type {}", type));
  }
}

void Server::connection(int fd) {
  Session s;
  gate::FrameReader reader(fd);
  std::unique_ptr<gate::Channel> channel;
  for (;;) {
    wire::Header h;
    std::span<const uint8_t> payload;
    const std::string why = reader.next(&h, &payload);
    if (why == "closed") break;
    if (!why.empty()) {
      // The framing is lost: answer once, then drop this connection only.
      audit_.event("malformed", why);
      gate::send_frame(fd, wire::Type::kError, h.seq, wire::encode_error({EPROTO, why}));
      break;
    }
    if (h.type == static_cast<uint8_t>(wire::Type::kChannel)) {
      std::string refusal;
      if (!s.bound) refusal = "channel before hello";
      if (!payload.empty()) refusal = "malformed channel request";
      if (refusal.empty()) {
        auto c = gate::Channel::create(fd, spin_);
        if (c) {
          const uint8_t size[4] = {static_cast<uint8_t>(gate::Channel::kSize),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 8),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 16),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 24)};
          if (!gate::send_frame_with_fd(fd, wire::Type::kChannelOk, h.seq, size, (*c)->memfd())) {
            break;
          }
          channel = std::move(*c);
          break;  // from here on, messages come through the channel
        }
        refusal = c.error();
      }
      audit_.event("malformed", refusal);
      gate::send_frame(fd, wire::Type::kError, h.seq, wire::encode_error({EPROTO, refusal}));
      continue;
    }
    if (auto answer = dispatch(s, h.type, payload, false)) {
      gate::send_frame(fd, *answer, h.seq, s.out);
    }
  }
  if (channel) serve_channel(s, *channel);
  {
    std::lock_guard lock(mu_);
    open_fds_.erase(fd);
  }
  close(fd);
  if (s.bound) monitor_.task_exited(s.task);
}

void Server::serve_channel(Session& s, gate::Channel& channel) {
  std::vector<uint8_t> request;  // the monitor's own copy of each request
  for (;;) {
    uint8_t type = 0;
    uint32_t len = 0;
    const auto next = channel.next_request(&type, &len, &request);
    if (next == gate::Channel::Next::kClosed || stopping_) return;
    if (next == gate::Channel::Next::kOversized) {
      const std::string why = fmt::format("request of {} bytes exceeds {}", len, wire::kMaxPayload);
      audit_.event("malformed", why);
      channel.answer(static_cast<uint8_t>(wire::Type::kError), wire::encode_error({EPROTO, why}));
      continue;
    }
    const auto answer = dispatch(s, type, request, true);
    channel.answer(static_cast<uint8_t>(answer.value_or(wire::Type::kJobEndOk)), s.out);
  }
}

}  // namespace contego::monitor
