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
#include <linux/close_range.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <mutex>
#include <string>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <thread>
#include <vector>

#include "base/unique_fd.h"
#include "intercept/seccomp/call_handler.h"
#include "intercept/seccomp/lineage.h"
#include "intercept/seccomp/notification_channel.h"
#include "intercept/seccomp/reach.h"
#include "intercept/seccomp/scheduling.h"
#include "intercept/seccomp/uapi_fallback.h"

namespace contego::intercept::seccomp {
namespace {

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
void supervise(Started& s, ListenerChannel& channel, const FdRange& range, const Options& options,
               gate::Endpoint& endpoint, RunResult& result) {
  s.release();
  CallHandler handler(channel, range, options, endpoint, result);
  // The loop blocks in SECCOMP_IOCTL_NOTIF_RECV itself (channel.receive(),
  // not poll() then RECV): only a task waiting inside RECV gets the sync
  // wake-up, so the supervised thread hands the CPU straight to us. A
  // blocked RECV is not woken when the last supervised task goes away: the
  // watcher does that.
  install_wake_handler();
  Watch w;
  std::thread watcher([&] { watch(options, s, w); });
  seccomp_notif n{};
  bool closed_down = false;
  auto close_down_if_stopped = [&] {
    if (closed_down || !w.stop.load(std::memory_order_acquire)) return;
    closed_down = true;
    result.stopped = true;
    handler.close_down();
  };
  while (!w.done.load(std::memory_order_acquire)) {
    close_down_if_stopped();
    const int err = channel.receive(n);
    if (err == 0) {
      close_down_if_stopped();  // a call received after the stop is answered EIO
      handler.handle(n);
      continue;
    }
    // EINTR: the watcher (or another signal): look at `done`. ENOENT: the
    // task went away between the wake-up and the copy, or no task uses the
    // filter any more, and then RECV fails at once every time.
    if (err == EINTR) continue;
    if (err != ENOENT) break;
    // So wait here instead of calling RECV again: retrying would spin until
    // the watcher sets `done`, and a watcher that shares a single CPU with
    // this thread at the same SCHED_FIFO priority (`taskset -c N contego run
    // --rt`, or a one-core board) would never run.
    pollfd p{channel.fd(), POLLIN, 0};
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
  ListenerChannel channel(started->listener.get());
  if (options.sync_wakeup && channel.enable_sync_wakeup()) result.sync_wakeup = true;
  int old_policy = SCHED_OTHER;
  sched_param old_param{};
  pthread_getschedparam(pthread_self(), &old_policy, &old_param);
  const bool loop_realtime = apply_priority(options, started->child, result);
  supervise(*started, channel, range, options, endpoint, result);
  if (loop_realtime) pthread_setschedparam(pthread_self(), old_policy, &old_param);
  started->listener.reset();
  started->pidfd.reset();
  leave_undumpable();
  endpoint.task_exited(options.task);
  return result;
}

}  // namespace contego::intercept::seccomp
