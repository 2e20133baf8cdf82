// The seccomp filter `contego run` installs on the supervised program, built
// with libseccomp (architecture check, x32 rejection and the BPF layout are
// the library's) and exported as a classic BPF program, so that the child
// can install it between fork and exec with one async-signal-safe system
// call.
//
// What it sends to the supervisor (SECCOMP_RET_USER_NOTIF):
//  - open/openat/openat2/creat, execve/execveat, close_range,
//    nanosleep/clock_nanosleep: always;
//  - ioctl, read/write and their vector and positional forms, close, dup,
//    fcntl: when the descriptor (argument 0) is in the reserved range;
//  - dup2/dup3: when either descriptor is in it.
// io_uring_setup, io_uring_enter and io_uring_register fail with ENOSYS (a
// ring, its own or one received from another process, would reach the bus
// descriptors' stand-ins or the node without a system call the filter sees).
// What could reach the bus node by another name than a path the supervisor
// resolves fails with EPERM: chroot, pivot_root, mount (and the new mount
// API), setns, unshare/clone with CLONE_NEWUSER or CLONE_NEWNS, mknod/mknodat
// of a character or block device, open_by_handle_at, pidfd_getfd (another
// process's descriptors); clone3 fails with ENOSYS (its flags are in
// memory the filter cannot read; the C library then uses clone). A system call of another
// architecture or ABI kills the process. Everything else is allowed.
#ifndef CONTEGO_INTERCEPT_SECCOMP_FILTER_H_
#define CONTEGO_INTERCEPT_SECCOMP_FILTER_H_

#include <linux/filter.h>
#include <vector>

#include "base/result.h"

namespace contego::intercept::seccomp {

// The reserved descriptor range [first, first + count): 64 descriptors,
// 64-aligned, at the top of the program's RLIMIT_NOFILE. The alignment lets
// the filter test membership with one masked comparison.
struct FdRange {
  int first;
  int count;
};
inline constexpr int kReservedFds = 64;
FdRange reserved_range();

// The filter for `range` (which must be 64 descriptors, 64-aligned).
Result<std::vector<sock_filter>> build_filter(FdRange range);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_FILTER_H_
