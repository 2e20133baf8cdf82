#include "intercept/seccomp/filter.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cstdint>
#include <functional>
#include <gtest/gtest.h>
#include <linux/seccomp.h>
#include <string>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>

namespace contego::intercept::seccomp {
namespace {

// Runs `body` in a child under the filter without a listener (a notified
// call then fails with ENOSYS). Returns the wait status.
int under_filter(const std::function<int()>& body) {
  auto filter = build_filter(reserved_range());
  EXPECT_TRUE(filter.ok()) << (filter.ok() ? "" : filter.error());
  if (!filter.ok()) return -1;
  sock_fprog prog{static_cast<unsigned short>(filter->size()), filter->data()};
  const pid_t pid = fork();
  if (pid == 0) {
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 ||
        syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER, 0, &prog) != 0) {
      _exit(100);
    }
    _exit(body());
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

int exit_code(int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status); }

TEST(SeccompFilter, ReservedRangeIsAlignedAndBelowTheLimit) {
  const FdRange r = reserved_range();
  rlimit lim{};
  getrlimit(RLIMIT_NOFILE, &lim);
  EXPECT_EQ(r.count, kReservedFds);
  EXPECT_EQ(r.first % kReservedFds, 0);
  if (lim.rlim_cur >= 128 && lim.rlim_cur != RLIM_INFINITY && lim.rlim_cur <= (1u << 20)) {
    EXPECT_LE(static_cast<rlim_t>(r.first + r.count), lim.rlim_cur);
  }
  EXPECT_FALSE(build_filter({r.first + 1, kReservedFds}).ok());
}

TEST(SeccompFilter, OrdinaryDescriptorsPassAndReservedOnesAreNotified) {
  const FdRange r = reserved_range();
  const int status = under_filter([r] {
    const int devnull = open("/dev/null", O_WRONLY);  // notified: ENOSYS without a listener
    if (devnull != -1 || errno != ENOSYS) return 1;
    if (write(STDERR_FILENO, "", 0) != 0) return 2;                 // not reserved: allowed
    if (write(r.first, "x", 1) != -1 || errno != ENOSYS) return 3;  // reserved: notified
    if (write(r.first + r.count - 1, "x", 1) != -1 || errno != ENOSYS) return 4;
    if (write(r.first + r.count, "x", 1) != -1 || errno != EBADF) return 5;  // just above
    if (write(r.first - 1, "x", 1) != -1 || errno != EBADF) return 6;        // just below
    if (dup2(STDERR_FILENO, r.first) != -1 || errno != ENOSYS) return 7;     // either argument
    if (syscall(SYS_io_uring_setup, 1, nullptr) != -1 || errno != ENOSYS) return 8;
    // A ring made elsewhere (its descriptor received) is as unusable.
    if (syscall(SYS_io_uring_enter, 3, 1, 0, 0, nullptr, 0) != -1 || errno != ENOSYS) return 10;
    if (syscall(SYS_io_uring_register, 3, 0, nullptr, 0) != -1 || errno != ENOSYS) return 11;
    // Another process's descriptors, even its own child's (which ptrace
    // access rules, Yama's included, would let it take).
    const pid_t child = fork();
    if (child == 0) {
      pause();
      _exit(0);
    }
    const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, child, 0));
    const long taken = pidfd >= 0 ? syscall(SYS_pidfd_getfd, pidfd, 0, 0) : -1;
    const int taken_errno = errno;
    kill(child, SIGKILL);
    waitpid(child, nullptr, 0);
    if (pidfd >= 0 && (taken != -1 || taken_errno != EPERM)) return 12;
    // A negative descriptor is not in the range (low 32 bits compared).
    if (write(-1, "x", 1) != -1 || errno != EBADF) return 9;
    return 0;
  });
  EXPECT_EQ(exit_code(status), 0);
}

#if defined(__x86_64__)
TEST(SeccompFilter, X32SystemCallKillsTheProcess) {
  const int status = under_filter([] {
    syscall(SYS_getpid | 0x40000000);  // the x32 ABI's getpid
    return 0;
  });
  EXPECT_EQ(exit_code(status), -SIGSYS);
}

// getpid through the i386 entry (int 0x80). SIGSEGV goes back to the
// kernel's default first, with the raw system call: a sanitizer's handler
// would otherwise turn the fault into an ordinary exit and hide it.
long i386_getpid() {
  struct {
    void (*handler)(int);
    unsigned long flags;
    void (*restorer)();
    uint64_t mask;
  } dfl{SIG_DFL, 0, nullptr, 0};
  syscall(SYS_rt_sigaction, SIGSEGV, &dfl, nullptr, sizeof dfl.mask);
  long ret = 20;  // getpid in the i386 table
  asm volatile("int $0x80" : "+a"(ret) : : "memory");
  return ret;
}

// Why the kernel cannot run i386 system calls, or "" when it can. Decided by
// trying one in a child without the filter: the kernel's configuration says
// too little (CONFIG_IA32_EMULATION=y kernels can boot with it off, and some
// hypervisors refuse int 0x80 whatever the guest's configuration).
std::string why_no_ia32_emulation() {
  const pid_t pid = fork();
  if (pid == 0) _exit(i386_getpid() == syscall(SYS_getpid) ? 0 : 1);
  int status = 0;
  waitpid(pid, &status, 0);
  const int code = exit_code(status);
  if (code == 0) return "";
  if (code == -SIGSEGV) return "the kernel has no IA-32 emulation (int 0x80 raises SIGSEGV)";
  return "int 0x80 getpid did not return the process id (status " + std::to_string(code) + ")";
}

TEST(SeccompFilter, I386SystemCallKillsTheProcess) {
  if (const std::string why = why_no_ia32_emulation(); !why.empty()) GTEST_SKIP() << why;
  const int status = under_filter([] {
    i386_getpid();
    return 0;
  });
  EXPECT_EQ(exit_code(status), -SIGSYS);
}
#endif

}  // namespace
}  // namespace contego::intercept::seccomp
