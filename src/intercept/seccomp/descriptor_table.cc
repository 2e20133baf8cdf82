#include "intercept/seccomp/descriptor_table.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <sys/syscall.h>

namespace contego::intercept::seccomp {

Handle::Handle() : standin(open("/dev/null", O_RDWR | O_CLOEXEC)) {}

bool same_open_file(pid_t self, pid_t tid, int fd, int own) {
  constexpr int kKcmpFile = 0;  // KCMP_FILE
  const long r = syscall(SYS_kcmp, self, tid, kKcmpFile, own, fd);
  return r == 0 || (r < 0 && errno == ENOSYS);
}

bool Process::alive() const {
  return pidfd.valid() && syscall(SYS_pidfd_send_signal, pidfd.get(), 0, nullptr, 0) == 0;
}

bool thread_of(pid_t tgid, pid_t tid) { return syscall(SYS_tgkill, tgid, tid, 0) == 0; }

}  // namespace contego::intercept::seccomp
