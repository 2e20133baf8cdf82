// The seccomp user-notification enclave client (`contego run`).
//
// The supervised program runs under a seccomp filter (filter.h: architecture
// checked, inherited by every thread and child, irremovable) that turns its
// bus system calls into notifications for this supervisor:
//  - open/openat/openat2/creat: a path that names a bus for the program
//    (bus_path.h: resolved in the program's context, by name or by device
//    number) gets a placeholder
//    descriptor (/dev/null) installed by the supervisor at a number in a
//    reserved range; no real bus node is ever opened by the program;
//  - ioctl/read/write on reserved descriptors: emulated: arguments copied
//    once from the program, decoded (i2c_abi), checked and performed by the
//    trusted side (gate::Endpoint), results copied back, notification id
//    re-validated around every memory access. Never CONTINUEd;
//  - dup/dup2/dup3/fcntl(F_DUPFD) on reserved descriptors: emulated so that
//    bus descriptors stay in the range; a copy outside it is refused;
//  - close/close_range: bookkeeping, then continued (no payload);
//  - execve/execveat: O_CLOEXEC bus descriptors are forgotten, then continued;
//  - nanosleep/clock_nanosleep: a job boundary, then continued (no payload).
// Other system calls never reach the supervisor.
//
// The supervisor blocks in SECCOMP_IOCTL_NOTIF_RECV (so the descriptor's
// sync wake-up applies); a watcher thread ends the loop once no supervised
// process is left, interrupting the receive with a real-time signal
// (SIGRTMIN + 3, handled process-wide by a no-op handler without
// SA_RESTART, installed on first use and kept).
//
// The program never outlives its supervisor: the direct child asks for
// SIGKILL when the thread that forked it dies (PR_SET_PDEATHSIG, set before
// exec, after checking that this process is still its parent), so a killed
// `contego run` takes it along instead of leaving it to meet ENOSYS on a
// listener nobody holds. (Grandchildren do not inherit that: a supervisor
// killed with SIGKILL leaves them running, and their bus calls then fail
// with ENOSYS; stop_fd ends them too.)
//
// Out of the program's reach: from the moment the program may run, the
// supervisor is not dumpable (PR_SET_DUMPABLE 0, restored when run()
// returns), so a program of the same uid cannot ptrace it, read or write its
// memory (process_vm_writev, /proc/PID/mem) or copy its descriptors
// (pidfd_getfd); `contego run --user` runs the program under another uid
// altogether. The program executes the path resolved before the fork
// (PATH searched here), the one named to before_start.
//
// Thread-safety: run() calls the endpoint from the calling thread only;
// concurrent run()s are fine; the endpoint may be shared.
#ifndef CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_
#define CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_

#include <signal.h>

#include <cstdint>
#include <functional>
#include <string>
#include <sys/types.h>
#include <vector>

#include "base/result.h"
#include "gate/endpoint.h"
#include "intercept/seccomp/filter.h"

namespace contego::intercept::seccomp {

struct Options {
  uint16_t task = 0;              // task id from the image
  std::vector<std::string> argv;  // program and arguments (argv[0] is a path or a PATH name)
  bool sync_wakeup = true;        // SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP when the kernel has it
  // > 0: the program and the supervising thread run under SCHED_FIFO at this
  // (policy) priority; a refusal is reported in RunResult, not fatal.
  int realtime_priority = 0;
  // >= 0: the program (and all it starts) and the supervising thread run on
  // this CPU only, so that each call's hand-over stays on one CPU. Under
  // SCHED_FIFO the scheduler otherwise wakes the supervisor away from the
  // equal-priority program that is still running, and every call crosses
  // CPUs twice. A CPU that cannot be used fails run() before anything runs.
  int cpu = -1;
  // >= 0: when this descriptor becomes readable (e.g. a signalfd of SIGINT,
  // SIGTERM, SIGHUP; never read here), the supervisor ends the program: it
  // SIGKILLs the direct child and every supervised process it knows, and from
  // then on answers every intercepted call with EIO and SIGKILLs its caller.
  // run() still returns only once no supervised process is left.
  int stop_fd = -1;
  // Make the calling process a child subreaper (PR_SET_CHILD_SUBREAPER) for
  // the run, and reap the orphans it adopts: a program's descendant that
  // double-forks stays below its supervisor, so the monitor still knows it
  // for a supervised program's (docs/threat-model.md). `contego run` sets
  // it; a caller with children of its own to wait for (a test) must not.
  bool subreaper = false;
  // The descriptors beyond 0, 1 and 2 the program inherits (`contego run
  // --pass-fd`). Every other one its launcher left open without O_CLOEXEC is
  // closed at exec: a bus node opened by whoever started `contego run`
  // would otherwise reach the bus unchecked. None of these, nor 0-2, may be
  // an I2C bus node: run() refuses to start (fail closed).
  std::vector<int> pass_fds;
  // Called with a supervised process's pid at its first intercepted call
  // after it called execve (before that call is answered, and before any
  // bus call of the new image): ok to go on, or why its new executable may
  // not act for the task. Then every supervised process is ended, as by
  // stop_fd, and RunResult::identity_refused says why. `contego run --socket`
  // asks the monitor to check the task's binding again (docs/threat-model.md).
  std::function<Status(pid_t pid)> on_exec;
  // Called once, on the supervisor's watcher thread, when stop_fd becomes
  // readable and before the program is ended: `contego run` records the
  // signal there, so the log has it before the program's exit it causes.
  std::function<void()> on_stop;
  // The signal mask the program starts with (the caller's own mask when null:
  // a caller that blocks signals to wait for them passes its original mask).
  const sigset_t* child_sigmask = nullptr;
  // The program's credentials (`contego run --user`): set in the child
  // before the filter and before it runs anything of the program;
  // any failure ends it before exec (fail closed).
  bool set_credentials = false;
  uid_t uid = 0;
  gid_t gid = 0;
  std::vector<gid_t> groups;  // supplementary groups
  // Called once the program's process exists (its pid and the absolute path
  // it will execute) and before it runs anything: a `--socket` supervisor
  // says hello to the monitor here, vouching for it. A non-empty answer is
  // the reason not to start it; run() then fails with it.
  std::function<std::string(pid_t child, const std::string& exe)> before_start;
};

struct RunResult {
  int exit_code = 0;  // of the direct child
  int signal = 0;     // non-zero if it was killed by a signal
  uint64_t notifications = 0;
  uint64_t emulated = 0;              // bus calls emulated
  uint64_t peak_threads_tracked = 0;  // most threads remembered at once (bounded)
  bool sync_wakeup = false;
  bool realtime = false;         // SCHED_FIFO was applied
  bool one_cpu = false;          // the program and the supervising thread shared one CPU
  std::string realtime_error;    // why not, when it was asked for
  bool stopped = false;          // ended through stop_fd
  std::string identity_refused;  // why an exec ended the program (Options::on_exec)
};

// Runs the program to completion under supervision. Fails (without running
// anything) if the filter cannot be installed.
Result<RunResult> run(const Options& options, gate::Endpoint& endpoint);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_
