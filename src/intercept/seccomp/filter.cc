#include "intercept/seccomp/filter.h"

#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <seccomp.h>
#include <unistd.h>

#include <cstring>
#include <memory>
#include <string>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>

#include "base/unique_fd.h"

namespace contego::intercept::seccomp {
namespace {

struct CtxDeleter {
  void operator()(void* ctx) const { seccomp_release(ctx); }
};

// Syscalls the supervisor always sees.
constexpr int kAlways[] = {
#ifdef __NR_open
    SCMP_SYS(open),
#endif
#ifdef __NR_creat
    SCMP_SYS(creat),
#endif
    SCMP_SYS(openat), SCMP_SYS(openat2),  SCMP_SYS(close_range),     SCMP_SYS(nanosleep),
    SCMP_SYS(execve), SCMP_SYS(execveat), SCMP_SYS(clock_nanosleep),
};

// Syscalls the supervisor sees when argument 0 is a reserved descriptor.
constexpr int kOnDescriptor[] = {
    SCMP_SYS(ioctl),    SCMP_SYS(read),     SCMP_SYS(write),  SCMP_SYS(readv),   SCMP_SYS(writev),
    SCMP_SYS(pread64),  SCMP_SYS(pwrite64), SCMP_SYS(preadv), SCMP_SYS(pwritev), SCMP_SYS(preadv2),
    SCMP_SYS(pwritev2), SCMP_SYS(close),    SCMP_SYS(dup),    SCMP_SYS(fcntl),
};

// ... when argument 0 or argument 1 is.
constexpr int kOnEitherDescriptor[] = {
#ifdef __NR_dup2
    SCMP_SYS(dup2),
#endif
    SCMP_SYS(dup3),
};

std::string why(const char* what, int rc) {
  return std::string("cannot build the seccomp filter: ") + what + ": " + std::strerror(-rc);
}

// Other ways to the bus node than a path the supervisor resolves: a root
// or namespace of the program's own (chroot, a new user or mount
// namespace, mount, pivot_root, setns), a node of its own (mknod of a
// character or block device), a file handle (open_by_handle_at) or another
// process's descriptor (pidfd_getfd: a bus node or a ring opened outside
// supervision). They fail with EPERM; clone3 (whose flags the filter cannot read) with ENOSYS,
// so that the C library falls back to clone, whose flags it can.
Status add_refusals(void* ctx) {
  const int eperm = SCMP_ACT_ERRNO(EPERM);
  constexpr int kRefused[] = {SCMP_SYS(chroot), SCMP_SYS(pivot_root),        SCMP_SYS(mount),
                              SCMP_SYS(setns),  SCMP_SYS(open_by_handle_at), SCMP_SYS(move_mount),
                              SCMP_SYS(fsopen), SCMP_SYS(open_tree),         SCMP_SYS(pidfd_getfd)};
  for (int nr : kRefused) {
    if (int rc = seccomp_rule_add(ctx, static_cast<uint32_t>(eperm), nr, 0); rc != 0) {
      return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
    }
  }
  if (int rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(ENOSYS), SCMP_SYS(clone3), 0); rc != 0) {
    return make_error(why("clone3", rc));
  }
  constexpr scmp_datum_t kNamespaces[] = {CLONE_NEWUSER, CLONE_NEWNS};
  for (scmp_datum_t flag : kNamespaces) {
    for (int nr : {SCMP_SYS(unshare), SCMP_SYS(clone)}) {
      if (int rc = seccomp_rule_add(ctx, static_cast<uint32_t>(eperm), nr, 1,
                                    SCMP_A0_64(SCMP_CMP_MASKED_EQ, flag, flag));
          rc != 0) {
        return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
      }
    }
  }
  for (scmp_datum_t type : {scmp_datum_t{S_IFCHR}, scmp_datum_t{S_IFBLK}}) {
#ifdef __NR_mknod
    if (int rc = seccomp_rule_add(ctx, static_cast<uint32_t>(eperm), SCMP_SYS(mknod), 1,
                                  SCMP_A1_32(SCMP_CMP_MASKED_EQ, S_IFMT, type));
        rc != 0) {
      return make_error(why("mknod", rc));
    }
#endif
    if (int rc = seccomp_rule_add(ctx, static_cast<uint32_t>(eperm), SCMP_SYS(mknodat), 1,
                                  SCMP_A2_32(SCMP_CMP_MASKED_EQ, S_IFMT, type));
        rc != 0) {
      return make_error(why("mknodat", rc));
    }
  }
  return {};
}

}  // namespace

FdRange reserved_range() {
  rlimit lim{};
  getrlimit(RLIMIT_NOFILE, &lim);
  rlim_t top = lim.rlim_cur;
  if (top == RLIM_INFINITY || top > (1 << 20)) top = 1 << 20;
  int first = (static_cast<int>(top) - kReservedFds) & ~(kReservedFds - 1);
  if (first < kReservedFds) first = kReservedFds;
  return {first, kReservedFds};
}

Result<std::vector<sock_filter>> build_filter(FdRange range) {
  if (range.count != kReservedFds || range.first % kReservedFds != 0 || range.first <= 0) {
    return make_error("cannot build the seccomp filter: the reserved range is not 64-aligned");
  }
  std::unique_ptr<void, CtxDeleter> ctx(seccomp_init(SCMP_ACT_ALLOW));
  if (!ctx) return make_error("cannot build the seccomp filter: seccomp_init failed");
  if (int rc = seccomp_attr_set(ctx.get(), SCMP_FLTATR_ACT_BADARCH, SCMP_ACT_KILL_PROCESS);
      rc != 0) {
    return make_error(why("bad-architecture action", rc));
  }
  for (int nr : kAlways) {
    if (int rc = seccomp_rule_add(ctx.get(), SCMP_ACT_NOTIFY, nr, 0); rc != 0) {
      return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
    }
  }
  // io_uring, whole: a ring made by another process and received over a
  // socket works without io_uring_setup. ENOSYS, as on a kernel built
  // without it, so that a library that probes for it falls back.
  for (int nr : {SCMP_SYS(io_uring_setup), SCMP_SYS(io_uring_enter), SCMP_SYS(io_uring_register)}) {
    if (int rc = seccomp_rule_add(ctx.get(), SCMP_ACT_ERRNO(ENOSYS), nr, 0); rc != 0) {
      return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
    }
  }
  if (Status s = add_refusals(ctx.get()); !s.ok()) return make_error(s.error());
  // An int descriptor, compared on its low 32 bits: in the range iff its
  // bits above the range's alignment equal the range's first descriptor.
  const scmp_datum_t mask = ~static_cast<uint32_t>(kReservedFds - 1);  // 32 bits, widened
  const auto first = static_cast<scmp_datum_t>(range.first);
  for (int nr : kOnDescriptor) {
    if (int rc = seccomp_rule_add(ctx.get(), SCMP_ACT_NOTIFY, nr, 1,
                                  SCMP_A0_32(SCMP_CMP_MASKED_EQ, mask, first));
        rc != 0) {
      return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
    }
  }
  // F_DUPFD / F_DUPFD_CLOEXEC of any descriptor at or above the range's
  // start: an ordinary descriptor may not be placed in the range.
  for (scmp_datum_t cmd : {scmp_datum_t{F_DUPFD}, scmp_datum_t{F_DUPFD_CLOEXEC}}) {
    if (int rc = seccomp_rule_add(ctx.get(), SCMP_ACT_NOTIFY, SCMP_SYS(fcntl), 2,
                                  SCMP_A1_32(SCMP_CMP_EQ, cmd), SCMP_A2_32(SCMP_CMP_GE, first));
        rc != 0) {
      return make_error(why("fcntl", rc));
    }
  }
  for (int nr : kOnEitherDescriptor) {
    for (unsigned arg = 0; arg < 2; ++arg) {
      const scmp_arg_cmp cmp = arg == 0 ? SCMP_A0_32(SCMP_CMP_MASKED_EQ, mask, first)
                                        : SCMP_A1_32(SCMP_CMP_MASKED_EQ, mask, first);
      if (int rc = seccomp_rule_add(ctx.get(), SCMP_ACT_NOTIFY, nr, 1, cmp); rc != 0) {
        return make_error(why(seccomp_syscall_resolve_num_arch(SCMP_ARCH_NATIVE, nr), rc));
      }
    }
  }
  // Export the program instead of loading it: the child installs it itself.
  const base::UniqueFd fd(memfd_create("contego-filter", MFD_CLOEXEC));
  if (!fd.valid()) return make_error(std::string("memfd_create: ") + std::strerror(errno));
  std::vector<sock_filter> program;
  const int rc = seccomp_export_bpf(ctx.get(), fd.get());
  const off_t size = lseek(fd.get(), 0, SEEK_END);
  if (rc == 0 && size > 0 && size % static_cast<off_t>(sizeof(sock_filter)) == 0) {
    program.resize(static_cast<size_t>(size) / sizeof(sock_filter));
    const auto bytes = static_cast<ssize_t>(size);
    if (pread(fd.get(), program.data(), static_cast<size_t>(size), 0) != bytes) program.clear();
  }
  if (rc != 0) return make_error(why("export", rc));
  if (program.empty() || program.size() > BPF_MAXINSNS) {
    return make_error("cannot build the seccomp filter: the exported program is unusable");
  }
  return program;
}

}  // namespace contego::intercept::seccomp
