#include "monitor/server.h"

#include <errno.h>
#include <unistd.h>

#include <cstring>
#include <fmt/core.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include "gate/socket.h"
#include "gate/wire.h"

namespace contego::monitor {

namespace wire = gate::wire;

Server::Server(Monitor& monitor, AuditLog& audit, std::map<std::string, uint16_t> tasks,
               std::set<uid_t> allowed_uids)
    : monitor_(monitor),
      audit_(audit),
      tasks_(std::move(tasks)),
      allowed_(std::move(allowed_uids)) {}

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

void Server::connection(int fd) {
  bool bound = false;
  uint16_t task = 0;
  // Per connection and reused for every message: no allocation per
  // exchange once they have grown (one recv and one send per transfer).
  gate::FrameReader reader(fd);
  gate::Transfer t;
  std::vector<uint8_t> out;
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
    auto refuse = [&](int err, const std::string& reason) {
      audit_.event("malformed", reason);
      gate::send_frame(fd, wire::Type::kError, h.seq, wire::encode_error({err, reason}));
    };
    switch (static_cast<wire::Type>(h.type)) {
      case wire::Type::kHello: {
        std::string name;
        if (std::string e = wire::decode_hello(payload, &name); !e.empty()) {
          refuse(EPROTO, e);
          break;
        }
        auto it = tasks_.find(name);
        if (bound || it == tasks_.end()) {
          refuse(EPERM, bound ? "already bound to a task" : "no task named '" + name + "'");
          break;
        }
        bound = true;
        task = it->second;
        gate::send_frame(fd, wire::Type::kHelloOk, h.seq, wire::encode_u16(task));
        break;
      }
      case wire::Type::kTransfer: {
        if (!bound) {
          refuse(EPERM, "transfer before hello");
          break;
        }
        if (std::string e = wire::decode_transfer(payload, &t); !e.empty()) {
          refuse(EINVAL, e);
          break;
        }
        const gate::TransferReply r = monitor_.transfer(task, t);
        wire::encode_reply(r, &out);
        gate::send_frame(fd, wire::Type::kReply, h.seq, out);
        break;
      }
      case wire::Type::kJobEnd:
        if (bound) monitor_.job_boundary(task);
        break;
      case wire::Type::kBusInfo: {
        if (payload.size() != 1) {
          refuse(EPROTO, "malformed bus info request");
          break;
        }
        wire::BusInfo info{monitor_.has_bus(payload[0]), monitor_.funcs(payload[0])};
        gate::send_frame(fd, wire::Type::kBusInfoOk, h.seq, wire::encode_bus_info(info));
        break;
      }
      default:
        refuse(EPROTO, fmt::format("unexpected message type {}", h.type));
        break;
    }
  }
  {
    std::lock_guard lock(mu_);
    open_fds_.erase(fd);
  }
  close(fd);
  if (bound) monitor_.task_exited(task);
}

}  // namespace contego::monitor
