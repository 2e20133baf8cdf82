// Which bus, if any, a path that a supervised program opens names: resolved
// in the program's context, not the supervisor's (issue 11, part 2).
//
// Two rules, either one makes it a bus:
//  - by name: the path, made absolute against the program's cwd or dirfd
//    (/proc/self and /proc/thread-self standing for the program's own
//    entries) and normalised lexically, is /dev/i2c-N or /dev/i2c/N. This
//    also serves buses with no node on this host (virtual buses).
//  - by what the kernel resolves: the path is walked component by component
//    from the program's root (/proc/TID/root) or its cwd or dirfd
//    (/proc/TID/cwd, /proc/TID/fd/N), with O_PATH: `..` stops at the
//    program's root; symbolic links are read and followed (at most 40);
//    procfs's `self` and `thread-self` are the program's; procfs magic links
//    (cwd, root, fd/N...) are followed by the kernel. The result, fstat'ed,
//    is a bus if it is a character device of the i2c-dev major (89): its
//    minor is the bus number.
// openat2's RESOLVE_IN_ROOT makes the dirfd the root; other RESOLVE_* flags
// only narrow what the kernel resolves; an unknown flag is refused (EINVAL).
// What is left: the program can change a link between this resolution and
// the kernel's own open (the supervisor lets the kernel open what is not a
// bus); the bus node's permissions must stop that race (docs/threat-model.md).
#ifndef CONTEGO_INTERCEPT_SECCOMP_BUS_PATH_H_
#define CONTEGO_INTERCEPT_SECCOMP_BUS_PATH_H_

#include <cstdint>
#include <string>
#include <sys/types.h>

#include "intercept/i2c_abi/bus_name.h"

namespace contego::intercept::seccomp {

struct BusPath {
  int bus = -1;    // the bus number, or -1: not a bus
  int refuse = 0;  // != 0: fail the open with this errno
};

inline constexpr unsigned kI2cDevMajor = 89;

// `tid`: the calling thread; `dirfd`: AT_FDCWD or the program's descriptor;
// `resolve`: openat2's resolve flags (0 for open/openat/creat);
// `nofollow`: O_NOFOLLOW was given (a final symbolic link is not followed).
BusPath resolve_bus_path(pid_t tid, int dirfd, const std::string& path, uint64_t resolve,
                         bool nofollow);

// The names: intercept/i2c_abi/bus_name.h, the one parser of bus node names.
using intercept::bus_number;
using intercept::lexical_normalise;

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_BUS_PATH_H_
