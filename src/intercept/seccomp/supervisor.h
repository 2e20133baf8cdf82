// The seccomp user-notification enclave client (`contego run`).
//
// The supervised program runs under a seccomp filter (filter.h: architecture
// checked, inherited by every thread and child, irremovable) that turns its
// bus system calls into notifications for this supervisor:
//  - open/openat/openat2/creat: a /dev/i2c-N path gets a placeholder
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
// Thread-safety: run() calls the endpoint from the calling thread only;
// concurrent run()s are fine; the endpoint may be shared.
#ifndef CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_
#define CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_

#include <cstdint>
#include <string>
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
};

struct RunResult {
  int exit_code = 0;  // of the direct child
  int signal = 0;     // non-zero if it was killed by a signal
  uint64_t notifications = 0;
  uint64_t emulated = 0;              // bus calls emulated
  uint64_t peak_threads_tracked = 0;  // most threads remembered at once (bounded)
  bool sync_wakeup = false;
  bool realtime = false;       // SCHED_FIFO was applied
  std::string realtime_error;  // why not, when it was asked for
};

// Runs the program to completion under supervision. Fails (without running
// anything) if the filter cannot be installed.
Result<RunResult> run(const Options& options, gate::Endpoint& endpoint);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_SUPERVISOR_H_
