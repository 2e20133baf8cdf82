#include "intercept/seccomp/supervisor.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stddef.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <functional>
#include <linux/close_range.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <thread>
#include <vector>

#include "base/unique_fd.h"
#include "intercept/i2c_abi/i2c_abi.h"
#include "intercept/seccomp/audit_arch.h"
#include "intercept/seccomp/bus_path.h"
#include "intercept/seccomp/descriptor_table.h"
#include "intercept/seccomp/lineage.h"
#include "intercept/seccomp/reach.h"
#include "intercept/seccomp/remote_memory.h"
#include "intercept/seccomp/scheduling.h"
#include "intercept/seccomp/uapi_fallback.h"

namespace contego::intercept::seccomp {
namespace {

class Loop {
 public:
  Loop(int listener, FdRange range, const Options& options, gate::Endpoint& endpoint,
       RunResult& result)
      : listener_(listener),
        range_(range),
        options_(options),
        endpoint_(endpoint),
        result_(result) {}

  void handle(const seccomp_notif& n);
  // Fail-close: SIGKILLs every supervised process known; every later call
  // is answered with EIO and its caller killed.
  void close_down();

 private:
  bool in_range(uint64_t fd) const {
    return fd >= static_cast<uint64_t>(range_.first) &&
           fd < static_cast<uint64_t>(range_.first) + static_cast<uint64_t>(range_.count);
  }
  bool valid(uint64_t id) { return ioctl(listener_, SECCOMP_IOCTL_NOTIF_ID_VALID, &id) == 0; }
  void reply(uint64_t id, int64_t value, int err) {
    seccomp_notif_resp r{};
    r.id = id;
    r.val = err == 0 ? value : 0;
    r.error = err == 0 ? 0 : -err;
    ioctl(listener_, SECCOMP_IOCTL_NOTIF_SEND, &r);  // ENOENT: the caller is gone or interrupted
  }
  void continue_call(uint64_t id) {
    seccomp_notif_resp r{};
    r.id = id;
    r.flags = SECCOMP_USER_NOTIF_FLAG_CONTINUE;
    ioctl(listener_, SECCOMP_IOCTL_NOTIF_SEND, &r);
  }
  // Installs the handle's stand-in at `slot` and answers the call with the slot.
  int install(uint64_t id, int slot, bool cloexec, const Handle& h) {
    if (!h.standin.valid()) {
      reply(id, 0, EMFILE);
      return -1;
    }
    seccomp_notif_addfd a{};
    a.id = id;
    a.flags = SECCOMP_ADDFD_FLAG_SETFD | SECCOMP_ADDFD_FLAG_SEND;
    a.srcfd = static_cast<uint32_t>(h.standin.get());
    a.newfd = static_cast<uint32_t>(slot);
    a.newfd_flags = cloexec ? O_CLOEXEC : 0;
    return ioctl(listener_, SECCOMP_IOCTL_NOTIF_ADDFD, &a);
  }
  // A reserved number free in the program: none of its bus descriptors,
  // and no ordinary descriptor that landed there (a full table) is replaced.
  int free_slot(const Process& p, int minimum, pid_t tid) const {
    for (int fd = std::max(minimum, range_.first); fd < range_.first + range_.count; ++fd) {
      if (p.fds.count(fd) != 0) continue;
      const std::string link = "/proc/" + std::to_string(tid) + "/fd/" + std::to_string(fd);
      if (faccessat(AT_FDCWD, link.c_str(), F_OK, AT_SYMLINK_NOFOLLOW) != 0) return fd;
    }
    return -1;
  }
  // The process of a thread that is waiting in a notified call, or null when
  // it went away meanwhile.
  Process* process_of(pid_t tid, uint64_t id);
  void forget_the_dead();
  void open_call(const seccomp_notif& n, Process& p);
  // The handle of bus descriptor `fd` as cached for thread `tid`, unchecked
  // (the thread's process may be gone, its number reused), or null.
  std::shared_ptr<Handle> cached_handle(pid_t tid, int fd) const;
  void bus_call(const seccomp_notif& n, const std::shared_ptr<Handle>& h);
  void dup_call(const seccomp_notif& n, Process& p);

  int listener_;
  const pid_t self_ = getpid();  // once: glibc asks the kernel on every getpid()
  FdRange range_;
  const Options& options_;
  gate::Endpoint& endpoint_;
  RunResult& result_;
  std::map<pid_t, Process> processes_;  // by thread-group id
  std::map<pid_t, pid_t> tgid_;         // thread id -> thread-group id
  size_t sweep_at_ = 256;               // tgid_ size that triggers forget_the_dead()
  size_t execs_pending_ = 0;            // processes with exec_pending: no short way meanwhile
  bool closing_ = false;
};

void Loop::close_down() {
  closing_ = true;
  if (options_.subreaper) kill_descendants(getpid());  // also those never seen
  for (auto& [tgid, p] : processes_) {
    if (p.pidfd.valid()) syscall(SYS_pidfd_send_signal, p.pidfd.get(), SIGKILL, nullptr, 0);
  }
}

Process* Loop::process_of(pid_t tid, uint64_t id) {
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
void Loop::forget_the_dead() {
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

void Loop::open_call(const seccomp_notif& n, Process& p) {
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

std::shared_ptr<Handle> Loop::cached_handle(pid_t tid, int fd) const {
  const auto t = tgid_.find(tid);
  if (t == tgid_.end()) return nullptr;
  const auto p = processes_.find(t->second);
  if (p == processes_.end()) return nullptr;
  const auto h = p->second.fds.find(fd);
  return h == p->second.fds.end() ? nullptr : h->second;
}

void Loop::bus_call(const seccomp_notif& n, const std::shared_ptr<Handle>& h) {
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

void Loop::dup_call(const seccomp_notif& n, Process& p) {
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

void Loop::handle(const seccomp_notif& n) {
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

// Interrupts the supervisor's blocking SECCOMP_IOCTL_NOTIF_RECV (installed
// once, without SA_RESTART, and kept: concurrent run()s share it).
const int kWakeSignal = SIGRTMIN + 3;
void on_wake(int) {}
void install_wake_handler() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa {};
    sa.sa_handler = on_wake;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;  // no SA_RESTART: the RECV returns EINTR
    sigaction(kWakeSignal, &sa, nullptr);
  });
}

// A credential failure in the child, told to the parent through the pipe.
constexpr int kCredentialsFailed = 1 << 16;

// What the child of run() needs between fork and exec.
struct ChildStart {
  const Options& options;
  const std::string& program;  // resolved path, or "" (execvp reports the failure)
  char* const* argv;
  int to_parent, to_child;  // pipe ends
  const sigset_t& child_mask;
  pid_t supervisor;
  const sock_fprog* prog;
};

// The child: credentials, parent-death signal, the filter, the listener to
// the parent, its go-ahead, exec. Only async-signal-safe calls.
[[noreturn]] void start_program(const ChildStart& c) {
  // Only async-signal-safe calls from here to execvp.
  // Dumpable whatever a concurrent run() set: the supervisor takes the
  // listener from it (pidfd_getfd) before it runs the program.
  prctl(PR_SET_DUMPABLE, 1, 0, 0, 0);
  // The program's credentials first: a change of credentials clears the
  // parent-death signal. Raw system calls: this thread only, no C library
  // broadcast to threads that do not exist in the child.
  if (c.options.set_credentials &&
      (syscall(SYS_setgroups, c.options.groups.size(), c.options.groups.data()) != 0 ||
       syscall(SYS_setresgid, c.options.gid, c.options.gid, c.options.gid) != 0 ||
       syscall(SYS_setresuid, c.options.uid, c.options.uid, c.options.uid) != 0)) {
    const int failed = -(kCredentialsFailed + errno);
    (void)!write(c.to_parent, &failed, sizeof failed);
    _exit(126);
  }
  // Dies with the thread that forked it; if that happened already (the
  // parent is no longer the supervisor), give up before running anything.
  if (prctl(PR_SET_PDEATHSIG, SIGKILL, 0, 0, 0) != 0 || getppid() != c.supervisor) _exit(126);
  sigprocmask(SIG_SETMASK, &c.child_mask, nullptr);
  int fd = -1;
  if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) == 0) {
    // WAIT_KILLABLE_RECV: once the supervisor has taken a call, only a
    // fatal signal interrupts the program's wait for the answer. Without
    // it a signal cancels a call the supervisor may already have
    // performed: the program sees EINTR for a transfer that acted, or
    // (SA_RESTART) issues it again and it acts twice.
    fd = static_cast<int>(
        syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER,
                SECCOMP_FILTER_FLAG_NEW_LISTENER | SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV, c.prog));
  }
  int msg = fd >= 0 ? fd : -errno;
  if (write(c.to_parent, &msg, sizeof msg) != sizeof msg || fd < 0) _exit(126);
  char ack;
  if (read(c.to_child, &ack, 1) != 1) _exit(126);
  close(fd);  // a raw close: between fork and exec (see above)
  // Nothing the launcher left open goes on, but what the caller passes.
  if (syscall(SYS_close_range, 3u, ~0u, CLOSE_RANGE_CLOEXEC) != 0) _exit(126);
  for (int keep : c.options.pass_fds) {
    if (fcntl(keep, F_SETFD, 0) != 0) _exit(126);
  }
  if (!c.program.empty()) {
    execv(c.program.c_str(), c.argv);
  } else {
    execvp(c.argv[0], c.argv);
  }
  const int e = errno;
  (void)!write(STDERR_FILENO, "contego run: cannot execute the program\n", 40);
  _exit(e == ENOENT ? 127 : 126);
}

// The program started under the filter, stopped before exec until
// release() (see start_program); or why it could not be.
struct Started {
  pid_t child = -1;
  base::UniqueFd pidfd;
  base::UniqueFd listener;
  base::UniqueFd to_child;  // the go-ahead pipe's write end
  void release() {
    char ack = 1;
    (void)!write(to_child.get(), &ack, 1);
    to_child.reset();
  }
};

// A close-on-exec pipe.
struct Pipe {
  base::UniqueFd read_end, write_end;
  bool open() {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) return false;
    read_end.reset(fds[0]);
    write_end.reset(fds[1]);
    return true;
  }
};

Result<Started> start_child(const Options& options, const std::string& program, char* const* argv,
                            const sock_fprog& prog) {
  Pipe to_parent, to_child;
  if (!to_parent.open() || !to_child.open()) {
    return make_error(std::string("pipe: ") + strerror(errno));
  }
  sigset_t child_mask;
  if (options.child_sigmask != nullptr) {
    child_mask = *options.child_sigmask;
  } else {
    pthread_sigmask(SIG_SETMASK, nullptr, &child_mask);
  }
  const pid_t supervisor = getpid();
  const pid_t child = fork();
  if (child < 0) return make_error(std::string("fork: ") + strerror(errno));
  if (child == 0) {
    // Never returns: the child's copies of the UniqueFds are never destroyed.
    start_program({options, program, argv, to_parent.write_end.get(), to_child.read_end.get(),
                   child_mask, supervisor, &prog});
  }
  to_parent.write_end.reset();
  to_child.read_end.reset();
  int msg = 0;
  const ssize_t got = read(to_parent.read_end.get(), &msg, sizeof msg);
  to_parent.read_end.reset();
  auto abandon = [&](const std::string& why) -> Result<Started> {
    to_child.write_end.reset();
    kill(child, SIGKILL);
    waitpid(child, nullptr, 0);
    return make_error(why);
  };
  if (got == sizeof msg && msg == -EINVAL) {
    return abandon(
        "cannot install the seccomp filter: the kernel has no "
        "SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV (Linux 5.19 or later is needed, so that a "
        "signal cannot make a checked transfer act twice or act while reporting failure)");
  }
  if (got == sizeof msg && msg <= -kCredentialsFailed) {
    return abandon("cannot run the program as uid " + std::to_string(options.uid) + " gid " +
                   std::to_string(options.gid) + ": " + strerror(-msg - kCredentialsFailed));
  }
  if (got != sizeof msg || msg < 0) {
    return abandon(std::string("cannot install the seccomp filter: ") +
                   (got == sizeof msg ? strerror(-msg) : "child failed"));
  }
  base::UniqueFd pidfd(static_cast<int>(syscall(SYS_pidfd_open, child, 0)));
  base::UniqueFd listener(
      pidfd.valid() ? static_cast<int>(syscall(SYS_pidfd_getfd, pidfd.get(), msg, 0)) : -1);
  if (!listener.valid()) {
    return abandon(std::string("cannot take the notification descriptor: ") + strerror(errno));
  }
  if (options.before_start) {
    if (std::string why = options.before_start(child, program.empty() ? options.argv[0] : program);
        !why.empty()) {
      return abandon(why);
    }
  }
  return Started{child, std::move(pidfd), std::move(listener), std::move(to_child.write_end)};
}

// What the loop and its watcher thread share.
struct Watch {
  std::atomic<bool> done{false}, loop_left{false}, stop{false};
  ChildStatus child_status;
  pthread_t loop_thread = pthread_self();
};

// The watcher: waits for the last supervised task to go (POLLHUP on the
// listener, after the direct child and any grandchildren that outlive
// it) or for the stop descriptor, then interrupts the loop's RECV with
// kWakeSignal, repeating until the loop has seen it (a signal that lands
// just before the loop enters RECV would otherwise be lost).
void watch(const Options& options, const Started& s, Watch& w) {
  bool child_done = false;
  bool stopping = options.stop_fd < 0;
  for (;;) {
    // The listener first; the child and the stop descriptor while they matter.
    pollfd fds[3] = {{s.listener.get(), 0, 0}, {-1, POLLIN, 0}, {-1, POLLIN, 0}};
    fds[1].fd = child_done ? -1 : s.pidfd.get();
    fds[2].fd = stopping ? -1 : options.stop_fd;
    if (options.subreaper) reap_orphans(child_done ? -1 : s.child);
    // Ending the program ends all it started, whether or not the loop has
    // seen it (a grandchild asleep since before the stop).
    if (stopping && options.stop_fd >= 0 && options.subreaper) kill_descendants(getpid());
    // Adopted orphans are looked for every 50 ms (their exit signals no descriptor).
    if (poll(fds, 3, options.subreaper ? 50 : -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (!child_done && (fds[1].revents & POLLIN)) {
      child_done = true;
      w.child_status.reap(s.child);
    }
    if (!stopping && (fds[2].revents & (POLLIN | POLLHUP | POLLERR))) {
      // End the program: the direct child now, the others the loop knows
      // as soon as it sees `stop` (woken below).
      stopping = true;
      if (options.on_stop) options.on_stop();
      w.stop.store(true, std::memory_order_release);
      if (!child_done) syscall(SYS_pidfd_send_signal, s.pidfd.get(), SIGKILL, nullptr, 0);
      pthread_kill(w.loop_thread, kWakeSignal);
    }
    if (fds[0].revents & (POLLHUP | POLLERR | POLLNVAL)) break;  // no supervised task left
  }
  w.done.store(true, std::memory_order_release);
  while (!w.loop_left.load(std::memory_order_acquire)) {
    pthread_kill(w.loop_thread, kWakeSignal);
    usleep(1000);
  }
}

// Answers the program's calls until no supervised task is left.
void supervise(Started& s, const FdRange& range, const Options& options, gate::Endpoint& endpoint,
               RunResult& result) {
  seccomp_notif_sizes sizes{};
  syscall(SYS_seccomp, SECCOMP_GET_NOTIF_SIZES, 0, &sizes);
  std::vector<uint8_t> buf(std::max<size_t>(sizes.seccomp_notif, sizeof(seccomp_notif)));
  s.release();
  Loop loop(s.listener.get(), range, options, endpoint, result);
  // The loop blocks in SECCOMP_IOCTL_NOTIF_RECV itself (not poll() then
  // RECV): only a task waiting inside RECV gets the sync wake-up, so the
  // supervised thread hands the CPU straight to us. A blocked RECV is not
  // woken when the last supervised task goes away: the watcher does that.
  install_wake_handler();
  Watch w;
  std::thread watcher([&] { watch(options, s, w); });
  std::memset(buf.data(), 0, buf.size());
  auto* n = reinterpret_cast<seccomp_notif*>(buf.data());
  bool closed_down = false;
  auto close_down_if_stopped = [&] {
    if (closed_down || !w.stop.load(std::memory_order_acquire)) return;
    closed_down = true;
    result.stopped = true;
    loop.close_down();
  };
  while (!w.done.load(std::memory_order_acquire)) {
    close_down_if_stopped();
    if (ioctl(s.listener.get(), SECCOMP_IOCTL_NOTIF_RECV, n) == 0) {
      close_down_if_stopped();  // a call received after the stop is answered EIO
      loop.handle(*n);
      std::memset(buf.data(), 0, buf.size());  // RECV wants a zeroed buffer
      continue;
    }
    // EINTR: the watcher (or another signal): look at `done`. ENOENT: the
    // task went away between the wake-up and the copy, or no task uses the
    // filter any more, and then RECV fails at once every time.
    if (errno == EINTR) continue;
    if (errno != ENOENT) break;
    // So wait here instead of calling RECV again: retrying would spin until
    // the watcher sets `done`, and a watcher that shares a single CPU with
    // this thread at the same SCHED_FIFO priority (`taskset -c N contego run
    // --rt`, or a one-core board) would never run.
    pollfd p{s.listener.get(), POLLIN, 0};
    if (poll(&p, 1, -1) < 0 && errno != EINTR) break;
    if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) break;  // no supervised task left
  }
  w.loop_left.store(true, std::memory_order_release);
  watcher.join();
  result.stopped = w.stop.load(std::memory_order_acquire);  // the loop may have missed it
  if (!w.child_status.reaped) w.child_status.reap(s.child);
  result.exit_code = w.child_status.exit_code;
  result.signal = w.child_status.signal;
}

}  // namespace

Result<RunResult> run(const Options& options, gate::Endpoint& endpoint) {
  if (options.argv.empty()) return make_error("contego run: no program given");
  CpuPin pin;
  if (options.cpu >= 0) {
    if (Status s = pin.pin(options.cpu); !s.ok()) return make_error(s.error());
  }
  const FdRange range = reserved_range();
  auto filter = build_filter(range);
  if (!filter.ok()) return make_error(filter.error());
  sock_fprog prog{static_cast<unsigned short>(filter->size()), filter->data()};
  std::vector<char*> argv;
  for (const auto& s : options.argv) argv.push_back(const_cast<char*>(s.c_str()));
  argv.push_back(nullptr);
  const std::string program = resolve_program(options.argv[0]);
  if (Status s = check_inherited(options.pass_fds); !s.ok()) return make_error(s.error());
  if (options.subreaper && prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0) {
    return make_error(std::string("contego run: PR_SET_CHILD_SUBREAPER: ") + std::strerror(errno));
  }
  auto started = start_child(options, program, argv.data(), prog);
  if (!started.ok()) return make_error(started.error());
  // From here the program may run: out of its reach.
  enter_undumpable();
  RunResult result;
  result.one_cpu = on_one_cpu();
  if (options.sync_wakeup && ioctl(started->listener.get(), SECCOMP_IOCTL_NOTIF_SET_FLAGS,
                                   SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP) == 0) {
    result.sync_wakeup = true;
  }
  int old_policy = SCHED_OTHER;
  sched_param old_param{};
  pthread_getschedparam(pthread_self(), &old_policy, &old_param);
  const bool loop_realtime = apply_priority(options, started->child, result);
  supervise(*started, range, options, endpoint, result);
  if (loop_realtime) pthread_setschedparam(pthread_self(), old_policy, &old_param);
  started->listener.reset();
  started->pidfd.reset();
  leave_undumpable();
  endpoint.task_exited(options.task);
  return result;
}

}  // namespace contego::intercept::seccomp
