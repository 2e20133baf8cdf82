// The server's hello admission: who the peer is (kernel facts), whether it
// may run the task it names, and how many sessions the task already has.
#include <errno.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <fmt/core.h>
#include <sys/stat.h>
#include <sys/syscall.h>

#include "contego/session_room.h"

#include "base/errorf.h"
#include "base/unique_fd.h"
#include "monitor/process_group.h"
#include "monitor/server.h"

namespace contego::monitor {

namespace wire = gate::wire;

bool Server::descends_from_supervised(pid_t pid) {
  // The peer itself, then its ancestors (64 at most: deeper chains are not
  // built by a program's own forks within a hello's time).
  for (int depth = 0; depth < 64 && pid > 1; ++depth) {
    if (supervised_.contains(pid)) return true;
    const base::UniqueFd fd(static_cast<int>(syscall(SYS_pidfd_open, pid, 0)));
    if (!fd.valid()) return false;
    auto facts = process_facts(fd.get(), pid);
    if (!facts.ok()) return false;
    pid = facts->ppid;
  }
  return false;
}

// Hello's rule holds for every message: a supervised program and its
// descendants, whatever their uid, speak to the monitor only through their
// supervisor's session. A task's session (bound by its hello) transfers,
// ends jobs and asks bus facts; it never administers the monitor, so a task
// cannot clear the latch its own violations set.
Status Server::message_refusal(const Session& s, wire::Type type) {
  switch (type) {
    case wire::Type::kTransfer:
    case wire::Type::kJobEnd:
    case wire::Type::kRevouch:
      return {};  // bound sessions only (checked where they are answered)
    case wire::Type::kBusInfo:
      if (s.bound) return {};
      break;
    case wire::Type::kReset:
    case wire::Type::kStatus:
    case wire::Type::kReload:
      if (s.bound) {
        return errorf(
            "the connection speaks for task {}: a task's session may not "
            "administer the monitor",
            s.task);
      }
      break;
    default:
      return {};
  }
  base::MutexLock lock(mu_);
  if (descends_from_supervised(s.conn->pid)) {
    return errorf(
        "the peer (pid {}) is a program supervised by contego (or its child): it "
        "may not act on the monitor",
        s.conn->pid);
  }
  return {};
}

Status Server::identity_refusal(const Conn& c, const std::string& name, const wire::Vouch& vouch) {
  const std::optional<TaskBinding> binding = binding_of(name);
  const bool binds = binding && binding->binds();
  if (vouch.pid == 0 && !binds) return {};
  if (!c.pidfd.valid()) return make_error("the peer process cannot be pinned (pidfd)");
  auto peer = process_facts(c.pidfd.get(), c.pid);
  if (!peer.ok()) return make_error("the peer: " + peer.error());
  PeerFacts facts = *peer;
  facts.uid = c.uid;  // SO_PEERCRED: the credentials the peer connected with
  if (vouch.pid != 0) {
    // A supervisor speaking for its program: the program must be its child,
    // and a non-root supervisor can only have started a program of its own
    // uid. The binding is then checked against the program (what a parent
    // can claim for its child it could claim by letting the child connect).
    const pid_t child = static_cast<pid_t>(vouch.pid);
    const base::UniqueFd child_fd(static_cast<int>(syscall(SYS_pidfd_open, child, 0)));
    if (!child_fd.valid()) return errorf("the supervised program (pid {}) is gone", child);
    auto program = process_facts(child_fd.get(), child);
    if (!program.ok()) return make_error("the supervised program: " + program.error());
    if (program->ppid != c.pid) {
      return errorf("pid {} is not a child of the supervisor (pid {})", child, c.pid);
    }
    if (c.uid != 0 && c.uid != program->uid) {
      return errorf("a supervisor of uid {} speaks for a program of uid {}", c.uid, program->uid);
    }
    facts = *program;
    facts.exe_known = false;
    if (binds && binding->has_exe) {
      // The program has not executed yet: the path it will execute is the
      // supervisor's word, taken only from this very contego binary.
      if (supervisors_.empty() || !peer->exe_known) {
        return make_error(
            "the peer's executable cannot be read, so its word on the program's executable "
            "cannot be taken (a monitor checking `exe` must be able to read /proc/PID/exe of "
            "its peers: root or CAP_SYS_PTRACE)");
      }
      if (std::find(supervisors_.begin(), supervisors_.end(),
                    std::pair{peer->exe_dev, peer->exe_ino}) == supervisors_.end()) {
        return make_error(
            "the peer vouches for a program but is not a contego supervisor (its executable "
            "is neither the monitor's own nor the contego beside it)");
      }
      struct stat st {};
      facts.exe_known = stat(vouch.exe.c_str(), &st) == 0;
      facts.exe_dev = st.st_dev;
      facts.exe_ino = st.st_ino;
      facts.exe_path = vouch.exe;
    }
  }
  if (!binds) return {};
  return binding_mismatch(name, *binding, facts);
}

Status Server::admit(Session& s, const std::string& name, uint16_t task, const wire::Vouch& vouch) {
  const Conn& c = *s.conn;
  {
    // As for a task's sessions below: a supervisor whose last program just
    // exited is listed until that session's thread notices the hang-up.
    base::MutexLock lock(mu_);
    if (descends_from_supervised(c.pid) && session_ending(-1, c.pid)) {
      lock.wait_for(session_ended_, std::chrono::seconds(2),
                    [&]() REQUIRES(mu_) { return !descends_from_supervised(c.pid) || stopping_; });
    }
    if (descends_from_supervised(c.pid)) {
      return make_error(
          "the peer is a program supervised by contego (or its child): its supervisor "
          "speaks for it; it may not open a connection of its own");
    }
  }
  if (Status st = identity_refusal(c, name, vouch); !st.ok()) return st;
  const std::optional<TaskBinding> binding = binding_of(name);
  const uint32_t allowed = binding ? binding->sessions : 1;
  const pid_t mine = session_unit(c.pid);
  base::MutexLock lock(mu_);
  // The task's live sessions counted by unit, as contego.ko counts them
  // (contego/session_room.h): the processes of a script, or a controller and
  // its forked worker, are one. A process keeps one connection per task: its
  // own second one is counted apart, as another session.
  struct Room {
    bool left;
    uint32_t live;
  };
  auto room = [&]() REQUIRES(mu_) {
    contego_session_room r;
    contego_room_start(&r, static_cast<uintptr_t>(mine), allowed);
    bool own = false, more = true;
    for (const auto& o : conns_) {
      if (!more || o->task != task || o.get() == &c) continue;
      own = own || o->pid == c.pid;
      const pid_t unit = o->pid == c.pid ? 0 : session_unit(o->pid);
      if (unit > 0) more = contego_room_count(&r, static_cast<uintptr_t>(unit)) != 0;
    }
    for (const HandedSession& h : handed_) {
      if (more && h.task == task && group_leader_lives(h.leader)) {
        more = contego_room_count(&r, static_cast<uintptr_t>(h.leader)) != 0;
      }
    }
    return Room{!own && contego_room_left(&r) != 0, r.n + (own ? 1u : 0u)};
  };
  // A program that just exited (one i2cset after another, each under the
  // preload client) still holds its session until its connection's thread
  // notices the hang-up (within the channel's poll interval): wait for that
  // rather than refuse its successor. A live peer is refused at once.
  if (!room().left && session_ending(task, 0)) {
    lock.wait_for(session_ended_, std::chrono::seconds(2),
                  [&]() REQUIRES(mu_) { return room().left || stopping_; });
  }
  if (const Room now = room(); !now.left) {
    return errorf("task '{}' already has {} live session(s) (the policy allows {})", name, now.live,
                  allowed);
  }
  ++live_sessions_[task];
  s.group = group_of(c.pid);
  s.conn->task = task;
  s.bound = true;
  s.task = task;
  s.task_name = name;
  if (vouch.pid != 0) {
    s.vouched = static_cast<pid_t>(vouch.pid);
    supervised_.insert(c.pid);
    supervised_.insert(s.vouched);
  }
  return {};
}

// The identity a hello established can change when the program executes
// another file: its supervisor sees the execve and asks again before the
// new image's first call is answered. The process must be below the
// supervisor (`contego run` is a subreaper, so its descendants stay there);
// the binding is checked against the executable the kernel reports now.
Status Server::revouch_refusal(const Session& s, pid_t pid) {
  {
    base::MutexLock lock(mu_);
    bool below = false;
    pid_t p = pid;
    for (int depth = 0; depth < 64 && p > 1 && !below; ++depth) {
      const base::UniqueFd fd(static_cast<int>(syscall(SYS_pidfd_open, p, 0)));
      if (!fd.valid()) break;
      auto facts = process_facts(fd.get(), p);
      if (!facts.ok()) break;
      below = facts->ppid == s.conn->pid;
      p = facts->ppid;
    }
    if (!below)
      return errorf("pid {} is not a process of the supervisor (pid {})", pid, s.conn->pid);
  }
  const std::optional<TaskBinding> binding = binding_of(s.task_name);
  if (!binding || !binding->has_exe) return {};  // exe alone can change
  const base::UniqueFd fd(static_cast<int>(syscall(SYS_pidfd_open, pid, 0)));
  if (!fd.valid()) return errorf("pid {} is gone", pid);
  auto facts = process_facts(fd.get(), pid);
  if (!facts.ok()) return make_error("the program: " + facts.error());
  if (!facts->exe_known) {
    return make_error(
        "the program's executable cannot be read, so a task bound by `exe` cannot be checked "
        "after an exec (the monitor needs root or CAP_SYS_PTRACE)");
  }
  return binding_mismatch(s.task_name, *binding, *facts);
}

wire::Type Server::revouch(Session& s, std::span<const uint8_t> payload) {
  std::string name;
  wire::Vouch vouch;
  auto refuse = [&](int err, const std::string& why) {
    s.out = wire::encode_error({err, why});
    return wire::Type::kError;
  };
  if (Status st = wire::decode_hello(payload, &name, &vouch); !st.ok() || vouch.pid == 0) {
    return refuse(EPROTO, st.ok() ? "a re-vouch names no process" : st.error());
  }
  if (!s.bound || s.vouched == 0 || name != s.task_name) {
    return refuse(EPERM, "a re-vouch comes only from the supervisor that vouched for the task");
  }
  const auto pid = static_cast<pid_t>(vouch.pid);
  const Status st = revouch_refusal(s, pid);
  audit_.event(st.ok() ? "identity" : "identity-refused",
               fmt::format("task {} ({}): pid {} executed {}{}", s.task, name, pid, vouch.exe,
                           st.ok() ? "" : ": " + st.error()));
  if (!st.ok()) return refuse(EACCES, st.error());
  s.out.clear();
  return wire::Type::kRevouchOk;
}

bool Server::session_ending(int task, pid_t pid) const {
  for (const auto& c : conns_) {
    if ((pid != 0 ? c->pid != pid : c->task != task) || c->done || !c->fd.valid()) continue;
    pollfd p{c->fd.get(), POLLRDHUP, 0};
    if (poll(&p, 1, 0) > 0 && (p.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0) return true;
  }
  return false;
}

void Server::end_session(Session& s) {
  if (!s.bound) return;  // a refused or missing hello drives nothing
  // A session handed to its script's leader at the goodbye ends with the
  // leader (end_handed_sessions), not here.
  if (!s.handed) monitor_.task_exited(s.task);
  base::MutexLock lock(mu_);
  if (auto it = live_sessions_.find(s.task); it != live_sessions_.end() && --it->second == 0) {
    live_sessions_.erase(it);
  }
  s.conn->task = -1;
  session_ended_.notify_all();
  if (s.vouched != 0) {
    supervised_.erase(supervised_.find(s.conn->pid));
    supervised_.erase(supervised_.find(s.vouched));
  }
}

void Server::goodbye(Session& s, int32_t wait_status) {
  // Settled now, as the process exits and while its parent waits for it: a
  // script's leader is still alive for each of its commands, however fast
  // they follow one another.
  if (s.handed || !contego_session_hands_to_leader(wait_status, static_cast<uintptr_t>(s.conn->pid),
                                                   static_cast<uintptr_t>(s.group),
                                                   group_leader_lives(s.group) ? 1 : 0)) {
    return;
  }
  // Pinned now, while it leads the group: a pid freed later is not it.
  base::UniqueFd leader(static_cast<int>(syscall(SYS_pidfd_open, s.group, 0)));
  if (!leader.valid() || !group_leader_lives(s.group)) return;
  base::MutexLock lock(mu_);
  s.handed = true;
  // One session per task and leader: the commands of a script end once.
  if (std::none_of(handed_.begin(), handed_.end(), [&](const HandedSession& h) {
        return h.task == s.task && h.leader == s.group;
      })) {
    handed_.push_back({s.task, s.group, std::move(leader)});
    ++live_sessions_[s.task];
    wake();  // the accept loop watches the leader from now on
  }
}

bool Server::end_handed_sessions() {
  std::vector<HandedSession> ended;
  {
    base::MutexLock lock(mu_);
    for (auto it = handed_.begin(); it != handed_.end();) {
      pollfd p{it->leader_fd.get(), POLLIN, 0};
      if (poll(&p, 1, 0) == 0) {
        ++it;
        continue;
      }
      ended.push_back(std::move(*it));
      it = handed_.erase(it);
    }
  }
  for (const HandedSession& h : ended) {
    monitor_.task_ended(h.task, fmt::format("ended with its process group's leader (pid {}), "
                                            "to which its process handed its session",
                                            h.leader));
  }
  base::MutexLock lock(mu_);
  for (const HandedSession& h : ended) {
    if (auto it = live_sessions_.find(h.task); it != live_sessions_.end() && --it->second == 0) {
      live_sessions_.erase(it);
    }
  }
  if (!ended.empty()) session_ended_.notify_all();
  return !handed_.empty();
}

}  // namespace contego::monitor
