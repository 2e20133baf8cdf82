#include "intercept/seccomp/lineage.h"

#include <errno.h>

#include <string>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>

#include "intercept/seccomp/bus_path.h"

namespace contego::intercept::seccomp {

Status check_inherited(const std::vector<int>& pass_fds) {
  std::vector<int> fds = {0, 1, 2};
  fds.insert(fds.end(), pass_fds.begin(), pass_fds.end());
  for (int fd : fds) {
    struct stat st {};
    if (fstat(fd, &st) != 0) {
      if (fd <= 2) continue;  // a closed standard descriptor passes nothing
      return make_error("contego run: --pass-fd " + std::to_string(fd) +
                        ": not an open descriptor");
    }
    if (S_ISCHR(st.st_mode) && major(st.st_rdev) == kI2cDevMajor) {
      return make_error("contego run: descriptor " + std::to_string(fd) +
                        " is an I2C bus node (/dev/i2c-" + std::to_string(minor(st.st_rdev)) +
                        "): the program would reach the bus unchecked through it; refusing to "
                        "start");
    }
  }
  return {};
}

void ChildStatus::reap(pid_t child) {
  int status = 0;
  pid_t r;
  do {
    r = waitpid(child, &status, 0);
  } while (r < 0 && errno == EINTR);
  if (r != child) return;
  reaped = true;
  if (WIFEXITED(status)) exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) {
    signal = WTERMSIG(status);
    exit_code = 128 + signal;
  }
}

void reap_orphans(pid_t child) {
  for (;;) {
    siginfo_t info{};
    if (waitid(P_ALL, 0, &info, WEXITED | WNOHANG | WNOWAIT) != 0 || info.si_pid == 0) return;
    if (info.si_pid == child) return;  // first in line: reaped by its watcher, then the rest
    waitpid(info.si_pid, nullptr, WNOHANG);
  }
}

}  // namespace contego::intercept::seccomp
