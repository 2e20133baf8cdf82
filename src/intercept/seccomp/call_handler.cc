#include "intercept/seccomp/call_handler.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <linux/close_range.h>
#include <string>
#include <sys/syscall.h>

#include "intercept/i2c_abi/i2c_abi.h"
#include "intercept/seccomp/audit_arch.h"
#include "intercept/seccomp/bus_path.h"
#include "intercept/seccomp/lineage.h"
#include "intercept/seccomp/remote_memory.h"

namespace contego::intercept::seccomp {

int CallHandler::install(uint64_t id, int slot, bool cloexec, const Handle& h) {
  if (!h.standin.valid()) {
    reply(id, 0, EMFILE);
    return -1;
  }
  return channel_.add_fd(id, h.standin.get(), slot, cloexec);
}

int CallHandler::free_slot(const Process& p, int minimum, pid_t tid) const {
  for (int fd = std::max(minimum, range_.first); fd < range_.first + range_.count; ++fd) {
    if (p.fds.count(fd) != 0) continue;
    const std::string link = "/proc/" + std::to_string(tid) + "/fd/" + std::to_string(fd);
    if (faccessat(AT_FDCWD, link.c_str(), F_OK, AT_SYMLINK_NOFOLLOW) != 0) return fd;
  }
  return -1;
}

void CallHandler::close_down() {
  closing_ = true;
  if (options_.subreaper) kill_descendants(getpid());  // also those never seen
  for (auto& [tgid, p] : processes_) {
    if (p.pidfd.valid()) syscall(SYS_pidfd_send_signal, p.pidfd.get(), SIGKILL, nullptr, 0);
  }
}

Process* CallHandler::process_of(pid_t tid, uint64_t id) {
  // Numbers are reused once a thread or process is gone, so a cached answer
  // is checked before it is trusted: the thread must still belong to that
  // thread group (skipped for a main thread, whose id is the group's), and
  // the process must be the one recorded (its pidfd). A stale answer is
  // dropped and the thread looked up afresh in /proc.
  auto t = tgid_.find(tid);
  if (t != tgid_.end() && t->second != tid && !thread_of(t->second, tid)) {
    tgid_.erase(t);
    t = tgid_.end();
  }
  if (t != tgid_.end()) {
    auto it = processes_.find(t->second);
    if (it != processes_.end()) {
      if (it->second.alive()) return &it->second;
      processes_.erase(it);  // a new process under a dead one's number
    }
    tgid_.erase(t);
  }
  if (tgid_.size() >= sweep_at_) forget_the_dead();
  pid_t tgid = tid;
  pid_t ppid = 0;
  {
    std::ifstream status("/proc/" + std::to_string(tid) + "/status");
    std::string line;
    while (std::getline(status, line)) {
      if (line.rfind("Tgid:", 0) == 0) tgid = std::stoi(line.substr(5));
      if (line.rfind("PPid:", 0) == 0) ppid = std::stoi(line.substr(5));
    }
  }
  auto it = processes_.find(tgid);
  if (it != processes_.end() && it->second.alive()) {
    tgid_[tid] = tgid;
    result_.peak_threads_tracked = std::max<uint64_t>(result_.peak_threads_tracked, tgid_.size());
    return &it->second;
  }
  if (it != processes_.end()) processes_.erase(it);
  base::UniqueFd pidfd(static_cast<int>(syscall(SYS_pidfd_open, tgid, 0)));
  // The notification still pending means its thread is alive, so the pidfd
  // (opened before this check) names the process that made the call.
  if (!pidfd.valid() || !valid(id)) return nullptr;
  tgid_[tid] = tgid;
  result_.peak_threads_tracked = std::max<uint64_t>(result_.peak_threads_tracked, tgid_.size());
  // A new process: a forked child shares its parent's open bus descriptors
  // (same open file descriptions, so the same address and flags).
  Process& p = processes_[tgid];
  p.pidfd = std::move(pidfd);
  auto parent = processes_.find(ppid);
  if (parent != processes_.end() && ppid != 0 && parent->second.alive()) {
    p.fds = parent->second.fds;
    p.cloexec = parent->second.cloexec;
  }
  return &p;
}

// Drops the threads and processes that are gone, so a long-running program
// that keeps creating threads does not grow these maps without bound.
void CallHandler::forget_the_dead() {
  for (auto it = processes_.begin(); it != processes_.end();) {
    if (it->second.alive()) {
      ++it;
      continue;
    }
    if (it->second.exec_pending) --execs_pending_;
    it = processes_.erase(it);
  }
  for (auto it = tgid_.begin(); it != tgid_.end();) {
    it = thread_of(it->second, it->first) ? std::next(it) : tgid_.erase(it);
  }
  sweep_at_ = std::max<size_t>(256, 2 * tgid_.size());
}

void CallHandler::open_call(const seccomp_notif& n, Process& p) {
  const auto& a = n.data.args;
  RemoteMemory mem(static_cast<pid_t>(n.pid));
  int dirfd = AT_FDCWD;
  uint64_t path_addr = 0;
  uint64_t flags = 0;
  uint64_t resolve = 0;
  if (n.data.nr == __NR_openat || n.data.nr == __NR_openat2) {
    dirfd = static_cast<int>(a[0]);
    path_addr = a[1];
    flags = a[2];
    if (n.data.nr == __NR_openat2) {
      uint64_t how[3] = {0, 0, 0};  // struct open_how: flags, mode, resolve
      if (a[3] < sizeof how) return reply(n.id, 0, EINVAL);
      if (!mem.read(a[2], how, sizeof how)) return reply(n.id, 0, EFAULT);
      flags = how[0];
      resolve = how[2];
    }
#ifdef __NR_open
  } else if (n.data.nr == __NR_open) {
    path_addr = a[0];
    flags = a[1];
#endif
#ifdef __NR_creat
  } else {  // creat
    path_addr = a[0];
    flags = O_CREAT | O_WRONLY | O_TRUNC;
#endif
  }
  std::string path;
  if (!read_path(mem, path_addr, &path)) return reply(n.id, 0, EFAULT);
  if (!valid(n.id)) return;
  const BusPath named =
      resolve_bus_path(static_cast<pid_t>(n.pid), dirfd, path, resolve, (flags & O_NOFOLLOW) != 0);
  if (named.refuse != 0) return reply(n.id, 0, named.refuse);
  const int bus = named.bus;
  if (bus < 0) return continue_call(n.id);  // not a bus: the kernel opens it
  if (!endpoint_.has_bus(static_cast<uint8_t>(bus))) return reply(n.id, 0, ENOENT);
  const int slot = free_slot(p, 0, static_cast<pid_t>(n.pid));
  if (slot < 0) return reply(n.id, 0, EMFILE);
  auto h = std::make_shared<Handle>();
  if (install(n.id, slot, (flags & O_CLOEXEC) != 0, *h) < 0) return;
  h->state.bus = static_cast<uint8_t>(bus);
  p.fds[slot] = h;
  if ((flags & O_CLOEXEC) != 0) p.cloexec.insert(slot);
}

std::shared_ptr<Handle> CallHandler::cached_handle(pid_t tid, int fd) const {
  const auto t = tgid_.find(tid);
  if (t == tgid_.end()) return nullptr;
  const auto p = processes_.find(t->second);
  if (p == processes_.end()) return nullptr;
  const auto h = p->second.fds.find(fd);
  return h == p->second.fds.end() ? nullptr : h->second;
}

void CallHandler::bus_call(const seccomp_notif& n, const std::shared_ptr<Handle>& h) {
  const auto& a = n.data.args;
  RemoteMemory mem(static_cast<pid_t>(n.pid));
  i2c_abi::Decoded d;
  const long nr = n.data.nr;
  if (nr == __NR_ioctl) {
    d = i2c_abi::decode_ioctl(h->state, static_cast<unsigned long>(a[1]), a[2], mem,
                              endpoint_.funcs(h->state.bus));
  } else if (nr == __NR_write) {
    d = i2c_abi::decode_write(h->state, a[1], a[2], mem);
  } else if (nr == __NR_read) {
    d = i2c_abi::decode_read(h->state, a[1], a[2]);
  } else if (nr == __NR_pread64 || nr == __NR_pwrite64 || nr == __NR_preadv || nr == __NR_pwritev ||
             nr == __NR_preadv2 || nr == __NR_pwritev2) {
    return reply(n.id, 0, ESPIPE);  // i2c-dev has no file position
  } else {
    return reply(n.id, 0, EINVAL);  // readv/writev: not offered by the emulation
  }
  if (d.action == i2c_abi::Decoded::Action::kReturn) return reply(n.id, d.value, d.err);
  // The arguments are copied; make sure they came from the call we are answering.
  if (!valid(n.id)) return;
  ++result_.emulated;
  const gate::TransferReply r = endpoint_.transfer(options_.task, d.transfer);
  // Results are copied back only into the call we are answering: the id is
  // re-validated before the first write into the program (a write-only call
  // copies nothing back and saves that system call).
  ValidatedWrites out(mem, [this, id = n.id] { return valid(id); });
  const int64_t ret = i2c_abi::complete(d.completion, r, out);
  if (ret < 0) return reply(n.id, 0, static_cast<int>(-ret));
  reply(n.id, ret, 0);
}

void CallHandler::dup_call(const seccomp_notif& n, Process& p) {
  const auto& a = n.data.args;
  const long nr = n.data.nr;
  const int oldfd = static_cast<int>(a[0]);
  auto old = p.fds.find(oldfd);
  if (old != p.fds.end() &&
      !same_open_file(self_, static_cast<pid_t>(n.pid), oldfd, old->second->standin.get())) {
    p.cloexec.erase(oldfd);  // closed or replaced by a CLONE_FILES sibling
    p.fds.erase(old);
    return reply(n.id, 0, EBADF);
  }
  if (nr == __NR_dup || nr == __NR_fcntl) {
    if (old == p.fds.end()) {
      // An ordinary descriptor: F_DUPFD may not place it in the reserved
      // range (the filter notifies only that case).
      const bool dupfd = nr == __NR_fcntl && (static_cast<int>(a[1]) == F_DUPFD ||
                                              static_cast<int>(a[1]) == F_DUPFD_CLOEXEC);
      if (dupfd && !in_range(static_cast<uint32_t>(oldfd))) return reply(n.id, 0, EINVAL);
      return continue_call(n.id);  // not a bus descriptor
    }
    int minimum = 0;
    bool cloexec = false;
    if (nr == __NR_fcntl) {
      const int cmd = static_cast<int>(a[1]);
      if (cmd == F_SETFD) {
        if ((a[2] & FD_CLOEXEC) != 0) {
          p.cloexec.insert(oldfd);
        } else {
          p.cloexec.erase(oldfd);
        }
      }
      if (cmd != F_DUPFD && cmd != F_DUPFD_CLOEXEC) return continue_call(n.id);
      minimum = static_cast<int>(a[2]);
      cloexec = cmd == F_DUPFD_CLOEXEC;
    }
    const int slot = free_slot(p, minimum, static_cast<pid_t>(n.pid));
    if (slot < 0) return reply(n.id, 0, EMFILE);
    auto handle = old->second;
    if (install(n.id, slot, cloexec, *handle) >= 0) {
      p.fds[slot] = handle;
      if (cloexec) p.cloexec.insert(slot);
    }
    return;
  }
  // dup2 / dup3
  const int newfd = static_cast<int>(a[1]);
  const bool new_in_range = in_range(static_cast<uint32_t>(newfd));
  if (old == p.fds.end()) {
    // Only bus descriptors live in the reserved range.
    return reply(n.id, 0, new_in_range ? EBADF : 0);
  }
  if (!new_in_range) return reply(n.id, 0, EPERM);  // a bus descriptor never leaves the range
  if (newfd == oldfd) {
#ifdef __NR_dup2
    if (nr == __NR_dup2) return reply(n.id, newfd, 0);
#endif
    return reply(n.id, 0, EINVAL);
  }
  const bool cloexec = nr == __NR_dup3 && (a[2] & O_CLOEXEC) != 0;
  auto handle = old->second;
  if (install(n.id, newfd, cloexec, *handle) >= 0) {
    p.fds[newfd] = handle;
    if (cloexec) {
      p.cloexec.insert(newfd);
    } else {
      p.cloexec.erase(newfd);
    }
  }
}

void CallHandler::handle(const seccomp_notif& n) {
  ++result_.notifications;
  if (n.data.arch != kAuditArch) return reply(n.id, 0, ENOSYS);  // the filter kills first
  const long nr = n.data.nr;
  if ((nr == __NR_nanosleep || nr == __NR_clock_nanosleep) && !closing_) {
    endpoint_.job_boundary(options_.task);
    return continue_call(n.id);  // a sleep carries no payload
  }
  // The common call, a read, write or ioctl on a bus descriptor the caller
  // is known to hold, goes the short way: kcmp proves that the caller's
  // descriptor is the handle's stand-in, and that alone decides the answer
  // (a bus call does not look at the process). So the cached thread and
  // process are not checked for liveness first (a system call or two per
  // command): a stale entry passes kcmp only with the very file the caller
  // holds. Anything else (not cached, kcmp fails or is missing) goes the
  // full way below.
  if (!closing_ && execs_pending_ == 0 &&
      (nr == __NR_write || nr == __NR_ioctl || nr == __NR_read)) {
    const int fd = static_cast<int>(n.data.args[0]);
    if (auto h = cached_handle(static_cast<pid_t>(n.pid), fd);
        h != nullptr &&
        proven_same_open_file(self_, static_cast<pid_t>(n.pid), fd, h->standin.get())) {
      return bus_call(n, h);
    }
  }
  Process* found = process_of(static_cast<pid_t>(n.pid), n.id);
  if (found == nullptr) return reply(n.id, 0, EIO);  // gone meanwhile, or no pidfd: fail closed
  if (closing_) {
    syscall(SYS_pidfd_send_signal, found->pidfd.get(), SIGKILL, nullptr, 0);
    return reply(n.id, 0, EIO);
  }
  Process& p = *found;
  if (p.exec_pending) {
    // The first call of what it executed: is that still the task's program?
    p.exec_pending = false;
    --execs_pending_;
    if (Status st = options_.on_exec(static_cast<pid_t>(n.pid)); !st.ok()) {
      if (result_.identity_refused.empty()) result_.identity_refused = st.error();
      close_down();
      return reply(n.id, 0, EIO);
    }
  }
  const auto& a = n.data.args;
  bool is_open = nr == __NR_openat || nr == __NR_openat2;
#ifdef __NR_open
  is_open = is_open || nr == __NR_open;
#endif
#ifdef __NR_creat
  is_open = is_open || nr == __NR_creat;
#endif
  if (is_open) return open_call(n, p);
  if (nr == __NR_execve || nr == __NR_execveat) {
    // The kernel closes O_CLOEXEC descriptors when the exec succeeds: forget
    // them now, so the new image cannot use a number it no longer holds.
    // (Were the exec to fail, those placeholders stay open but inert:
    // /dev/null answers ENOTTY, nothing reaches a bus.)
    for (int fd : p.cloexec) p.fds.erase(fd);
    p.cloexec.clear();
    if (options_.on_exec && !p.exec_pending) {
      p.exec_pending = true;
      ++execs_pending_;
    }
    return continue_call(n.id);
  }
  if (nr == __NR_close) {
    p.fds.erase(static_cast<int>(a[0]));
    p.cloexec.erase(static_cast<int>(a[0]));
    return continue_call(n.id);  // closes the placeholder; no payload
  }
  if (nr == __NR_close_range) {
    const uint32_t first = static_cast<uint32_t>(a[0]);
    const uint32_t last = static_cast<uint32_t>(a[1]);
    const bool mark_only = (a[2] & CLOSE_RANGE_CLOEXEC) != 0;
    for (auto it = p.fds.begin(); it != p.fds.end();) {
      const auto fd = static_cast<uint32_t>(it->first);
      if (fd < first || fd > last) {
        ++it;
      } else if (mark_only) {
        p.cloexec.insert(it->first);
        ++it;
      } else {
        p.cloexec.erase(it->first);
        it = p.fds.erase(it);
      }
    }
    return continue_call(n.id);
  }
  bool is_dup = nr == __NR_dup || nr == __NR_dup3 || nr == __NR_fcntl;
#ifdef __NR_dup2
  is_dup = is_dup || nr == __NR_dup2;
#endif
  if (is_dup) return dup_call(n, p);
  auto it = p.fds.find(static_cast<int>(a[0]));
  if (it == p.fds.end()) return continue_call(n.id);  // an inert descriptor that is not a bus
  if (!same_open_file(self_, static_cast<pid_t>(n.pid), it->first, it->second->standin.get())) {
    // Closed or replaced behind this process's back (a CLONE_FILES sibling):
    // no longer this bus.
    p.cloexec.erase(it->first);
    p.fds.erase(it);
    return reply(n.id, 0, EBADF);
  }
  auto handle = it->second;
  bus_call(n, handle);
}
}  // namespace contego::intercept::seccomp
