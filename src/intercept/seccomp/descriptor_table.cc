#include "intercept/seccomp/descriptor_table.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <sys/syscall.h>

namespace contego::intercept::seccomp {

Handle::Handle() : standin(open("/dev/null", O_RDWR | O_CLOEXEC)) {}

namespace {
// kcmp's answer: 0 for the same file, else another order or -1 (errno).
long compare_files(pid_t self, pid_t tid, int fd, int own) {
  constexpr int kKcmpFile = 0;  // KCMP_FILE
  return syscall(SYS_kcmp, self, tid, kKcmpFile, own, fd);
}
}  // namespace

bool same_open_file(pid_t self, pid_t tid, int fd, int own) {
  const long r = compare_files(self, tid, fd, own);
  return r == 0 || (r < 0 && errno == ENOSYS);
}

bool proven_same_open_file(pid_t self, pid_t tid, int fd, int own) {
  return compare_files(self, tid, fd, own) == 0;
}

bool Process::alive() const {
  return pidfd.valid() && syscall(SYS_pidfd_send_signal, pidfd.get(), 0, nullptr, 0) == 0;
}

bool thread_of(pid_t tgid, pid_t tid) { return syscall(SYS_tgkill, tgid, tid, 0) == 0; }

}  // namespace contego::intercept::seccomp
