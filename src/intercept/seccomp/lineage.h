// What a supervised program takes with it and leaves behind: the
// descriptors it inherits from whoever started `contego run`, and the
// orphans a subreaper supervisor adopts from it.
#ifndef CONTEGO_INTERCEPT_SECCOMP_LINEAGE_H_
#define CONTEGO_INTERCEPT_SECCOMP_LINEAGE_H_

#include <sys/types.h>
#include <vector>

#include "base/result.h"

namespace contego::intercept::seccomp {

// The descriptors the program will inherit (0-2 and `pass_fds`): each passed
// one open, and none of them a bus node (i2c-dev's major), which the program
// could use without a call the filter sends to the supervisor.
Status check_inherited(const std::vector<int>& pass_fds);

// How the direct child ended, once reaped (waitpid; EINTR retried).
struct ChildStatus {
  bool reaped = false;
  int exit_code = 0;
  int signal = 0;  // non-zero: killed by it (exit_code 128 + signal)
  void reap(pid_t child);
};

// Reaps the orphans a subreaper adopted, never `child` (the direct child,
// whose status its watcher keeps; -1 once it is reaped): an unreaped zombie
// holds the seccomp filter, and the listener would never hang up.
void reap_orphans(pid_t child);

// SIGKILLs every process below `self` (its children, theirs, ...) that runs
// under a seccomp filter (the program's, never a helper of the supervisor
// such as `contego run`'s guardian), as /proc shows them now, each pinned by a pidfd and its parent
// checked again first (a number reused meanwhile is left alone). A subreaper's orphans are its
// children, so nothing the program started escapes; called again until the
// listener hangs up, it also ends what was forked meanwhile. Returns how
// many were signalled.
size_t kill_descendants(pid_t self);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_LINEAGE_H_
