// Runs a program as on a kernel built without kcmp (CONFIG_KCMP unset): a
// seccomp filter answers every kcmp with ENOSYS, for the program and all it
// starts. `without_kcmp PROGRAM ARGS...`; exit 125 if the filter cannot be
// installed or does not take.
#include <errno.h>
#include <stddef.h>
#include <unistd.h>

#include <cstdio>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <sys/prctl.h>
#include <sys/syscall.h>

#include "intercept/seccomp/audit_arch.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: without_kcmp PROGRAM [ARGS...]\n");
    return 125;
  }
  sock_filter filter[] = {
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, arch)),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, contego::intercept::seccomp::kAuditArch, 0, 3),
      BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, nr)),
      BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, SYS_kcmp, 0, 1),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ERRNO | ENOSYS),
      BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
  };
  sock_fprog prog{sizeof filter / sizeof filter[0], filter};
  if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 ||
      syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER, 0, &prog) != 0) {
    std::perror("without_kcmp: cannot install the filter");
    return 125;
  }
  const pid_t self = getpid();
  if (syscall(SYS_kcmp, self, self, 0, 0, 0) != -1 || errno != ENOSYS) {
    std::fprintf(stderr, "without_kcmp: kcmp still answers\n");
    return 125;
  }
  execvp(argv[1], argv + 1);
  std::perror("without_kcmp: exec");
  return 127;
}
