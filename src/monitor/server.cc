#include "monitor/server.h"

#include <errno.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fmt/core.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <system_error>

#include "base/realtime.h"
#include "gate/channel.h"
#include "gate/socket.h"
#include "gate/wire.h"

namespace contego::monitor {

namespace wire = gate::wire;

namespace {

uint64_t now_us() { return monotonic_us(); }

}  // namespace

Server::Server(Monitor& monitor, AuditLog& audit, std::map<std::string, uint16_t> tasks,
               std::set<uid_t> allowed_uids, gate::SpinPolicy spin, bool realtime,
               ServerLimits limits)
    : monitor_(monitor),
      audit_(audit),
      tasks_(std::move(tasks)),
      allowed_(std::move(allowed_uids)),
      spin_(spin),
      realtime_(realtime),
      limits_(limits) {
  dev_t dev = 0;
  ino_t ino = 0;
  if (own_exe(&dev, &ino)) supervisors_.emplace_back(dev, ino);
}

bool Server::trust_supervisor(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return false;
  supervisors_.emplace_back(st.st_dev, st.st_ino);
  return true;
}

Server::~Server() {
  stop();
  std::vector<std::unique_ptr<Conn>> conns;
  {
    base::MutexLock lock(mu_);
    conns.swap(conns_);
  }
  for (auto& c : conns) {
    if (c->thread.joinable()) c->thread.join();
  }
  flush_suppressed(true);
  listen_fd_.reset();
  status_fd_.reset();
  if (!path_.empty()) unlink(path_.c_str());
  if (!status_path_.empty()) unlink(status_path_.c_str());
}

namespace {

// A listening Unix socket at `path` (a stale file replaced), mode 0660.
Status listen_at(const std::string& path, base::UniqueFd* fd) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) return make_error("socket path too long: " + path);
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  fd->reset(socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0));
  if (!fd->valid()) return make_error(std::string("socket: ") + strerror(errno));
  unlink(path.c_str());
  if (bind(fd->get(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    return make_error("cannot bind " + path + ": " + strerror(errno));
  }
  chmod(path.c_str(), 0660);
  if (::listen(fd->get(), 64) != 0) return make_error(std::string("listen: ") + strerror(errno));
  return {};
}

// Whether the peer on `fd` has `group` as its primary or a supplementary
// group, as the kernel recorded them when it connected.
bool peer_in_group(int fd, const ucred& cred, gid_t group) {
  if (cred.gid == group) return true;
  std::vector<gid_t> groups(64);
  socklen_t len = static_cast<socklen_t>(groups.size() * sizeof(gid_t));
  if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups.data(), &len) != 0) {
    if (errno != ERANGE) return false;
    groups.resize(len / sizeof(gid_t));
    if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, groups.data(), &len) != 0) return false;
  }
  groups.resize(len / sizeof(gid_t));
  return std::find(groups.begin(), groups.end(), group) != groups.end();
}

}  // namespace

Status Server::listen(const std::string& path) {
  if (Status st = listen_at(path, &listen_fd_); !st.ok()) return st;
  wake_fd_.reset(eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
  if (!wake_fd_.valid()) return make_error(std::string("eventfd: ") + strerror(errno));
  path_ = path;
  return {};
}

Status Server::listen_status(const std::string& path) {
  if (Status st = listen_at(path, &status_fd_); !st.ok()) return st;
  status_path_ = path;
  return {};
}

void Server::wake() {
  if (!wake_fd_.valid()) return;
  const uint64_t one = 1;
  (void)!write(wake_fd_.get(), &one, sizeof one);  // EAGAIN: already pending
}

size_t Server::live_connections() {
  base::MutexLock lock(mu_);
  size_t n = 0;
  for (const auto& c : conns_) n += c->done.load() ? 0 : 1;
  return n;
}

void Server::client_event(uid_t uid, const std::string& kind, const std::string& detail) {
  {
    base::MutexLock lock(events_mu_);
    const uint64_t now = now_us();
    EventBudget& b = budgets_[uid];
    if (now >= b.window_us + 1000000) {
      if (b.window_us == 0) wake();  // a new window: the accept loop ends it in 1 s
      if (b.suppressed > 0) {
        audit_.event("suppressed",
                     fmt::format("uid {}: {} client-error event(s) not written (over {} per "
                                 "second)",
                                 uid, b.suppressed, limits_.events_per_second));
      }
      b.window_us = now;
      b.written = 0;
      b.suppressed = 0;
    }
    if (limits_.events_per_second > 0 && b.written >= limits_.events_per_second) {
      ++b.suppressed;
      suppressed_total_.fetch_add(1);
      return;
    }
    ++b.written;
  }
  audit_.event(kind, detail);
}

void Server::refuse_peer(int fd, pid_t pid, uid_t uid, const std::string& why, int error,
                         const char* message) {
  client_event(uid, "peer-refused", fmt::format("pid {} uid {}{}", pid, uid, why));
  gate::send_frame(fd, wire::Type::kError, 0, wire::encode_error({error, message}));
}

void Server::flush_suppressed(bool all) {
  base::MutexLock lock(events_mu_);
  const uint64_t now = now_us();
  for (auto it = budgets_.begin(); it != budgets_.end();) {
    EventBudget& b = it->second;
    if (!all && now < b.window_us + 1000000) {
      ++it;
      continue;
    }
    if (b.suppressed > 0) {
      audit_.event("suppressed", fmt::format("uid {}: {} client-error event(s) not written (over "
                                             "{} per second)",
                                             it->first, b.suppressed, limits_.events_per_second));
    }
    it = budgets_.erase(it);
  }
}

int Server::housekeeping() {
  std::vector<std::unique_ptr<Conn>> finished;
  std::vector<std::pair<uid_t, int>> timed_out;
  uint64_t next_us = UINT64_MAX;
  {
    base::MutexLock lock(mu_);
    const uint64_t now = now_us();
    for (auto it = conns_.begin(); it != conns_.end();) {
      Conn& c = **it;
      if (c.done.load()) {
        finished.push_back(std::move(*it));
        it = conns_.erase(it);
        continue;
      }
      if (!c.hello.load() && c.hello_deadline_us != 0 && now >= c.hello_deadline_us &&
          !c.timed_out) {
        c.timed_out = true;
        shutdown(c.fd.get(), SHUT_RDWR);  // its thread sees the end and closes it
        timed_out.emplace_back(c.uid, c.fd.get());
      }
      if (!c.hello.load() && c.hello_deadline_us != 0 && !c.timed_out) {
        next_us = std::min(next_us, c.hello_deadline_us);
      }
      ++it;
    }
  }
  for (auto& c : finished) c->thread.join();
  for (const auto& [uid, fd] : timed_out) {
    hello_timeouts_.fetch_add(1);
    client_event(uid, "hello-timeout",
                 fmt::format("uid {}: no hello within {} ms: connection closed", uid,
                             limits_.hello_timeout_ms));
  }
  flush_suppressed(false);
  // A handed session's leader is looked at as often as a connection's
  // thread looks for its peer's hang-up.
  if (end_handed_sessions()) next_us = std::min(next_us, now_us() + 20'000);
  {
    base::MutexLock lock(events_mu_);
    for (const auto& [uid, b] : budgets_) next_us = std::min(next_us, b.window_us + 1000000);
  }
  if (next_us == UINT64_MAX) return -1;
  const uint64_t now = now_us();
  return next_us <= now ? 0
                        : static_cast<int>(std::min<uint64_t>((next_us - now + 999) / 1000, 60000));
}

void Server::serve() {
  AcceptReports reports;
  while (!stopping_) {
    const int timeout_ms = housekeeping();
    pollfd p[3] = {{wake_fd_.get(), POLLIN, 0},
                   {listen_fd_.get(), POLLIN, 0},
                   {status_fd_.get(), POLLIN, 0}};  // -1 (no status socket): ignored
    const int ready = poll(p, 3, timeout_ms);
    if (stopping_) break;
    if (ready <= 0) continue;
    if (p[0].revents & POLLIN) {
      uint64_t count = 0;
      (void)!read(wake_fd_.get(), &count, sizeof count);
    }
    for (int i = 1; i < 3 && !stopping_; ++i) {
      if (p[i].revents & (POLLIN | POLLHUP | POLLERR)) accept_one(p[i].fd, i == 2, &reports);
    }
  }
  flush_suppressed(true);  // the counts of the last windows
}

void Server::accept_one(int listener, bool read_only, AcceptReports* reports) {
  base::UniqueFd fd(accept4(listener, nullptr, nullptr, SOCK_CLOEXEC));
  if (!fd.valid()) {
    const int err = errno;
    if (stopping_ || err == EINTR || err == EAGAIN || err == ECONNABORTED) return;
    // Out of descriptors or memory (EMFILE, ENFILE, ENOBUFS, ENOMEM) or
    // anything else: never the end of the monitor. The connections already
    // open are served on their own threads; the hello timeout and the
    // per-uid cap free descriptors; this loop retries after a pause.
    accept_failures_.fetch_add(1);
    ++reports->unreported;
    const uint64_t now = now_us();
    if (now >= reports->reported_us + 1000000) {
      const std::string what = fmt::format(
          "accept failed: {} ({} time(s) since the last report); still serving the "
          "open connections, retrying",
          strerror(err), reports->unreported);
      audit_.event("accept-failed", what);
      fmt::print(stderr, "contego monitor: {}\n", what);
      reports->reported_us = now;
      reports->unreported = 0;
    }
    usleep(50000);
    return;
  }
  ucred cred{};
  socklen_t len = sizeof cred;
  if (getsockopt(fd.get(), SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) {
    refuse_peer(fd.get(), cred.pid, cred.uid, "", EACCES, "peer uid not allowed");
    return;
  }
  // The status socket admits anyone who can reach it (its directory's
  // group): status() answers the operators and the status group, and
  // refuses the rest with the reason, audited.
  const bool status_group = status_group_ && peer_in_group(fd.get(), cred, *status_group_);
  if (!read_only && allowed_.count(cred.uid) == 0) {
    refuse_peer(fd.get(), cred.pid, cred.uid, "", EACCES, "peer uid not allowed");
    return;
  }
  if (limits_.connects_per_second > 0) {
    if (connects_.size() > 4096) connects_.clear();  // bounded; a fresh window for all
    auto& [window_us, opened] = connects_[cred.uid];
    const uint64_t now = now_us();
    if (now >= window_us + 1000000) {
      window_us = now;
      opened = 0;
    }
    if (++opened > limits_.connects_per_second) {
      over_rate_.fetch_add(1);
      refuse_peer(fd.get(), cred.pid, cred.uid,
                  fmt::format(": over {} new connections per second", limits_.connects_per_second),
                  EAGAIN, "reconnecting too fast for this uid");
      return;
    }
  }
  base::MutexLock lock(mu_);
  uint32_t& live = per_uid_[cred.uid];
  if (limits_.max_per_uid > 0 && live >= limits_.max_per_uid) {
    lock.unlock();
    over_cap_.fetch_add(1);
    refuse_peer(fd.get(), cred.pid, cred.uid,
                fmt::format(": over the cap of {} connections per uid", limits_.max_per_uid),
                EAGAIN, "too many connections for this uid");
    return;
  }
  ++live;
  auto c = std::make_unique<Conn>();
  c->pidfd.reset(peer_pidfd(fd.get(), cred.pid));  // -1: a hello for a bound task is refused
  c->fd = std::move(fd);
  c->uid = cred.uid;
  c->pid = cred.pid;
  c->read_only = read_only;
  c->status_group = status_group;
  c->hello_deadline_us =
      limits_.hello_timeout_ms > 0 ? now_us() + uint64_t{limits_.hello_timeout_ms} * 1000 : 0;
  Conn* raw = c.get();
  try {
    c->thread = std::thread([this, raw] { connection(raw); });
  } catch (const std::system_error&) {
    --live;
    lock.unlock();
    client_event(cred.uid, "peer-refused",
                 fmt::format("pid {} uid {}: no thread for the connection", cred.pid, cred.uid));
    usleep(50000);
    return;
  }
  conns_.push_back(std::move(c));
  lock.unlock();
  client_event(cred.uid, "peer", fmt::format("pid {} uid {}", cred.pid, cred.uid));
}

void Server::stop() {
  stopping_ = true;
  wake();
  if (listen_fd_.valid()) shutdown(listen_fd_.get(), SHUT_RDWR);
  if (status_fd_.valid()) shutdown(status_fd_.get(), SHUT_RDWR);
  base::MutexLock lock(mu_);
  for (const auto& c : conns_) {
    if (!c->done.load()) shutdown(c->fd.get(), SHUT_RDWR);
  }
  session_ended_.notify_all();  // a hello waiting for an ending session
}

// Answers one well-framed message into *out; returns the answer's type, or
// nullopt for a message that has none (job-end over the socket).
std::optional<wire::Type> Server::dispatch(Session& s, uint8_t type,
                                           std::span<const uint8_t> payload, bool channel) {
  auto refuse = [&](int err, const std::string& reason) {
    client_event(s.conn->uid, "malformed", fmt::format("uid {}: {}", s.conn->uid, reason));
    s.out = wire::encode_error({err, reason});
    return wire::Type::kError;
  };
  if (s.conn->read_only && static_cast<wire::Type>(type) != wire::Type::kStatus) {
    const std::string why = "the status socket answers status requests only";
    client_event(
        s.conn->uid, "request-refused",
        fmt::format("pid {} uid {}: message type {}: {}", s.conn->pid, s.conn->uid, type, why));
    s.out = wire::encode_error({EPERM, why});
    return wire::Type::kError;
  }
  switch (static_cast<wire::Type>(type)) {
    case wire::Type::kHello: {
      std::string name;
      wire::Vouch vouch;
      if (Status st = wire::decode_hello(payload, &name, &vouch); !st.ok()) {
        return refuse(EPROTO, st.error());
      }
      const std::optional<uint16_t> task = task_of(name);
      if (s.bound || !task) {
        return refuse(EPERM, s.bound ? "already bound to a task" : "no task named '" + name + "'");
      }
      if (Status st = admit(s, name, *task, vouch); !st.ok()) {
        hellos_refused_.fetch_add(1);
        client_event(s.conn->uid, "hello-refused",
                     fmt::format("pid {} uid {}: {}", s.conn->pid, s.conn->uid, st.error()));
        s.out = wire::encode_error({EACCES, st.error()});
        return wire::Type::kError;
      }
      s.conn->hello.store(true);
      const uint16_t priority = monitor_.task_priority(s.task);
      if (realtime_ && priority > 0) {
        // This thread checks the task's commands: it runs at the task's priority.
        if (Status st = make_thread_realtime(priority); !st.ok()) {
          audit_.event("realtime-refused", fmt::format("task {}: SCHED_FIFO {}: {}", s.task,
                                                       fifo_priority(priority), st.error()));
        }
      }
      s.out = wire::encode_hello_ok({s.task, priority});
      return wire::Type::kHelloOk;
    }
    case wire::Type::kTransfer: {
      if (!s.bound) return refuse(EPERM, "transfer before hello");
      if (Status st = wire::decode_transfer(payload, &s.transfer); !st.ok()) {
        return refuse(EINVAL, st.error());
      }
      // Refused here, where the event is rate-limited per peer (the monitor
      // would log each one).
      if (Status st = gate::validate(s.transfer); !st.ok()) return refuse(EINVAL, st.error());
      const gate::TransferReply r = monitor_.transfer(s.task, s.transfer);
      wire::encode_reply(r, &s.out);
      return wire::Type::kReply;
    }
    case wire::Type::kJobEnd:
      if (s.bound) monitor_.job_boundary(s.task);
      if (!channel) return std::nullopt;
      s.out.clear();  // the channel's slot needs an answer to be free again
      return wire::Type::kJobEndOk;
    case wire::Type::kGoodbye: {
      // A malformed one is refused; the session then ends as if none came.
      int32_t status = 0;
      if (Status st = wire::decode_goodbye(payload, &status); !st.ok()) {
        return refuse(EPROTO, st.error());
      }
      if (s.bound) goodbye(s, status);
      s.out.clear();
      return wire::Type::kGoodbyeOk;
    }
    case wire::Type::kBusInfo: {
      if (payload.size() != 1) return refuse(EPROTO, "malformed bus info request");
      if (Status st = message_refusal(s, wire::Type::kBusInfo); !st.ok()) {
        client_event(
            s.conn->uid, "request-refused",
            fmt::format("pid {} uid {}: bus info: {}", s.conn->pid, s.conn->uid, st.error()));
        s.out = wire::encode_error({EPERM, st.error()});
        return wire::Type::kError;
      }
      wire::BusInfo info{monitor_.has_bus(payload[0]), monitor_.funcs(payload[0])};
      s.out = wire::encode_bus_info(info);
      return wire::Type::kBusInfoOk;
    }
    case wire::Type::kReset:
      return reset(s, payload);
    case wire::Type::kRevouch:
      return revouch(s, payload);
    case wire::Type::kStatus:
      return status(s);
    case wire::Type::kReload:
      return reload(s, payload);
    default:
      return refuse(EPROTO, fmt::format("unexpected message type {}", type));
  }
}

// `contego reset DEVICE`: only root and the monitor's own uid may clear a
// latch; every request, granted or not, is audited.
wire::Type Server::reset(Session& s, std::span<const uint8_t> payload) {
  std::string device;
  const uid_t uid = s.conn->uid;
  auto answer_error = [&](int err, const std::string& reason) {
    s.out = wire::encode_error({err, reason});
    return wire::Type::kError;
  };
  if (Status st = wire::decode_hello(payload, &device); !st.ok()) {
    return answer_error(EPROTO, "malformed reset request (a device name of 1..64 bytes expected)");
  }
  if (Status st = message_refusal(s, wire::Type::kReset); !st.ok()) {
    audit_.event("reset-refused", fmt::format("device {}: uid {}: {}", device, uid, st.error()));
    return answer_error(EPERM, st.error());
  }
  if (uid != 0 && uid != geteuid()) {
    audit_.event("reset-refused", fmt::format("device {}: uid {} is neither root nor the "
                                              "monitor's uid {}",
                                              device, uid, geteuid()));
    return answer_error(EPERM, "only root or the monitor's uid may reset a latch");
  }
  const Result<bool> r = monitor_.reset_latch(device, uid);
  if (!r.ok()) return answer_error(ENOENT, r.error());
  s.out = {static_cast<uint8_t>(*r ? 1 : 0)};
  return wire::Type::kResetOk;
}

void Server::connection(Conn* conn) {
  Conn* const c = conn;
  const int fd = c->fd.get();
  Session s;
  s.conn = c;
  gate::FrameReader reader(fd);
  std::unique_ptr<gate::Channel> channel;
  for (;;) {
    wire::Header h;
    std::span<const uint8_t> payload;
    const gate::FrameStatus got = reader.next(&h, &payload);
    if (got.kind == gate::FrameStatus::Kind::kClosed) break;
    if (got.kind == gate::FrameStatus::Kind::kBroken) {
      const std::string& why = got.why;
      // The framing is lost: answer once, then drop this connection only.
      client_event(c->uid, "malformed", fmt::format("uid {}: {}", c->uid, why));
      gate::send_frame(fd, wire::Type::kError, h.seq, wire::encode_error({EPROTO, why}));
      break;
    }
    if (h.type == static_cast<uint8_t>(wire::Type::kChannel)) {
      std::string refusal;
      if (!s.bound) refusal = "channel before hello";
      if (!payload.empty()) refusal = "malformed channel request";
      if (refusal.empty()) {
        auto made = gate::Channel::create(fd, spin_);
        if (made) {
          const uint8_t size[4] = {static_cast<uint8_t>(gate::Channel::kSize),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 8),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 16),
                                   static_cast<uint8_t>(gate::Channel::kSize >> 24)};
          if (!gate::send_frame_with_fd(fd, wire::Type::kChannelOk, h.seq, size,
                                        (*made)->memfd())) {
            break;
          }
          channel = std::move(*made);
          break;  // from here on, messages come through the channel
        }
        refusal = made.error();
      }
      client_event(c->uid, "malformed", fmt::format("uid {}: {}", c->uid, refusal));
      gate::send_frame(fd, wire::Type::kError, h.seq, wire::encode_error({EPROTO, refusal}));
      continue;
    }
    if (auto answer = dispatch(s, h.type, payload, false)) {
      gate::send_frame(fd, *answer, h.seq, s.out);
    }
  }
  if (channel) serve_channel(s, *channel);
  end_session(s);
  base::MutexLock lock(mu_);
  c->fd.reset();
  c->pidfd.reset();
  if (auto it = per_uid_.find(c->uid); it != per_uid_.end() && --it->second == 0) {
    per_uid_.erase(it);
  }
  c->done.store(true);  // joined by the accept loop
  wake();
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
      client_event(s.conn->uid, "malformed", fmt::format("uid {}: {}", s.conn->uid, why));
      channel.answer(static_cast<uint8_t>(wire::Type::kError), wire::encode_error({EPROTO, why}));
      continue;
    }
    const auto answer = dispatch(s, type, request, true);
    channel.answer(static_cast<uint8_t>(answer.value_or(wire::Type::kJobEndOk)), s.out);
  }
}

}  // namespace contego::monitor
