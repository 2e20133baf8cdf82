// The supervisor's answer to each notified call (supervisor.h says which
// calls and how each is answered): what each supervised process holds of
// the buses, the emulation of bus calls through the endpoint, and the
// answers through a NotificationChannel. One call at a time, in the order
// received; the run loop, the watcher and the program's start are
// supervisor.cc's.
//
// Thread-safety: none; the thread that receives the calls handles them.
#ifndef CONTEGO_INTERCEPT_SECCOMP_CALL_HANDLER_H_
#define CONTEGO_INTERCEPT_SECCOMP_CALL_HANDLER_H_

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <linux/seccomp.h>
#include <map>
#include <memory>
#include <sys/types.h>

#include "gate/endpoint.h"
#include "intercept/seccomp/descriptor_table.h"
#include "intercept/seccomp/filter.h"
#include "intercept/seccomp/notification_channel.h"
#include "intercept/seccomp/supervisor.h"

namespace contego::intercept::seccomp {

class CallHandler {
 public:
  // Bus descriptors go to `range`; `options` and `result` are the run's.
  CallHandler(NotificationChannel& channel, FdRange range, const Options& options,
              gate::Endpoint& endpoint, RunResult& result)
      : channel_(channel), range_(range), options_(options), endpoint_(endpoint), result_(result) {}

  // Answers call `n` (or leaves it unanswered when it is no longer pending).
  void handle(const seccomp_notif& n);
  // Fail-close: SIGKILLs every supervised process known; every later call
  // is answered with EIO and its caller killed.
  void close_down();

 private:
  bool in_range(uint64_t fd) const {
    return fd >= static_cast<uint64_t>(range_.first) &&
           fd < static_cast<uint64_t>(range_.first) + static_cast<uint64_t>(range_.count);
  }
  bool valid(uint64_t id) { return channel_.valid(id); }
  void reply(uint64_t id, int64_t value, int err) { channel_.reply(id, value, err); }
  void continue_call(uint64_t id) { channel_.continue_call(id); }
  // Installs the handle's stand-in at `slot` and answers the call with the slot.
  int install(uint64_t id, int slot, bool cloexec, const Handle& h);
  // A reserved number free in the program: none of its bus descriptors,
  // and no ordinary descriptor that landed there (a full table) is replaced.
  int free_slot(const Process& p, int minimum, pid_t tid) const;
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

  NotificationChannel& channel_;
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

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_CALL_HANDLER_H_
