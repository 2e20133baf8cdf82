// What the supervisor knows of each supervised process's bus descriptors:
// the emulated bus behind each number, and the checks that tell whether a
// cached answer still holds (descriptor tables change behind its back, and
// thread and process numbers are reused).
#ifndef CONTEGO_INTERCEPT_SECCOMP_DESCRIPTOR_TABLE_H_
#define CONTEGO_INTERCEPT_SECCOMP_DESCRIPTOR_TABLE_H_

#include <map>
#include <memory>
#include <set>
#include <sys/types.h>

#include "base/unique_fd.h"
#include "intercept/i2c_abi/i2c_abi.h"

namespace contego::intercept::seccomp {

// One opened bus: its state and its own stand-in file (a /dev/null opened
// for it alone), so that kcmp can tell whether a program's descriptor is
// still this bus's (a CLONE_FILES sibling may have closed it, or put
// something else at its number) before anything acts.
struct Handle {
  Handle();
  i2c_abi::FdState state;
  base::UniqueFd standin;
};

// True if descriptor `fd` of thread `tid` is the very file `own` is in this
// process, `self`. (A kernel without kcmp, CONFIG_KCMP unset: the
// descriptor tables are trusted.)
bool same_open_file(pid_t self, pid_t tid, int fd, int own);
// The same, but false when the kernel cannot tell (no kcmp): for a shortcut
// that is only sound when the comparison was really made.
bool proven_same_open_file(pid_t self, pid_t tid, int fd, int own);

struct Process {
  std::map<int, std::shared_ptr<Handle>> fds;
  std::set<int> cloexec;  // bus descriptors that a successful exec closes
  // Names this very process, not its number: once it is reaped the number may
  // be handed to a new process, which must not inherit these descriptors.
  base::UniqueFd pidfd;
  // It called execve: its identity is checked again (Options::on_exec) at
  // its next intercepted call, before that call is answered.
  bool exec_pending = false;
  bool alive() const;
};

// True while `tid` is a thread of the thread group `tgid` (signal 0 delivers
// nothing; it only looks the thread up).
bool thread_of(pid_t tgid, pid_t tid);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_DESCRIPTOR_TABLE_H_
