#include "intercept/seccomp/lineage.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>

#include "base/unique_fd.h"
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

namespace {

// The parent of `pid` from /proc/PID/stat (after the command's closing
// parenthesis: state, then ppid); -1 if gone.
pid_t parent_of(pid_t pid) {
  char path[32];
  (void)std::snprintf(path, sizeof path, "/proc/%d/stat", pid);
  const base::UniqueFd fd(::open(path, O_RDONLY | O_CLOEXEC));
  if (!fd.valid()) return -1;
  char buf[512];
  const ssize_t n = ::read(fd.get(), buf, sizeof buf - 1);
  if (n <= 0) return -1;
  buf[n] = '\0';
  const char* close = std::strrchr(buf, ')');
  char state = 0;
  int ppid = -1;
  if (close == nullptr || std::sscanf(close + 1, " %c %d", &state, &ppid) != 2) return -1;
  return ppid;
}

// Whether `pid` runs under a seccomp filter (/proc/PID/status "Seccomp: 2"):
// the supervised program and everything it started do, and cannot drop it;
// the supervisor's own helpers (`contego run`'s guardian) do not.
bool filtered(pid_t pid) {
  char path[32];
  (void)std::snprintf(path, sizeof path, "/proc/%d/status", pid);
  std::FILE* f = std::fopen(path, "re");
  if (f == nullptr) return false;
  char line[256];
  bool yes = false;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, "Seccomp:", 8) == 0) {
      yes = std::atoi(line + 8) == 2;
      break;
    }
  }
  (void)std::fclose(f);  // read only: nothing to lose
  return yes;
}

}  // namespace

size_t kill_descendants(pid_t self) {
  std::map<pid_t, std::vector<pid_t>> children;
  DIR* proc = opendir("/proc");
  if (proc == nullptr) return 0;
  while (const dirent* e = readdir(proc)) {
    char* end = nullptr;
    const long pid = std::strtol(e->d_name, &end, 10);
    if (end == e->d_name || *end != '\0' || pid <= 0 || pid == self) continue;
    const pid_t ppid = parent_of(static_cast<pid_t>(pid));
    if (ppid > 0) children[ppid].push_back(static_cast<pid_t>(pid));
  }
  closedir(proc);
  size_t signalled = 0;
  std::vector<std::pair<pid_t, pid_t>> todo;  // (pid, its parent)
  for (pid_t c : children[self]) todo.emplace_back(c, self);
  while (!todo.empty()) {
    const auto [pid, parent] = todo.back();
    todo.pop_back();
    for (pid_t c : children[pid]) todo.emplace_back(c, pid);
    const base::UniqueFd pidfd(static_cast<int>(syscall(SYS_pidfd_open, pid, 0)));
    if (!pidfd.valid() || parent_of(pid) != parent) continue;  // gone, or the number reused
    if (!filtered(pid)) continue;  // not the program's: a helper of the supervisor
    if (syscall(SYS_pidfd_send_signal, pidfd.get(), SIGKILL, nullptr, 0) == 0) ++signalled;
  }
  return signalled;
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
