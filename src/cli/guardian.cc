#include "cli/guardian.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <string.h>
#include <unistd.h>

#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>

namespace contego::cli {

Guardian::Guardian(const std::function<int()>& on_loss, std::string* error) {
  // A socket pair, not a pipe: the release is sent with MSG_NOSIGNAL, so a
  // guardian killed meanwhile (by a program under the same uid) costs no SIGPIPE.
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
    *error = std::string("socketpair: ") + strerror(errno);
    return;
  }
  const pid_t pid = fork();
  if (pid < 0) {
    *error = std::string("fork: ") + strerror(errno);
    close(fds[0]);
    close(fds[1]);
    return;
  }
  if (pid == 0) {
    close(fds[1]);
    // Not traceable by the program (which runs under the same uid unless
    // told otherwise); SIGINT/SIGTERM/SIGHUP stay blocked as in the parent.
    (void)prctl(PR_SET_DUMPABLE, 0, 0, 0, 0);
    (void)prctl(PR_SET_NAME, "contego-guard", 0, 0, 0);
    const int parent = static_cast<int>(syscall(SYS_pidfd_open, getppid(), 0));
    char word = 0;
    ssize_t n;
    do {
      n = read(fds[0], &word, 1);
    } while (n < 0 && errno == EINTR);
    if (n == 1) _exit(0);  // released: the supervisor ended cleanly
    // Its descriptors close before its exit is complete: wait for that, so
    // that its lock on the audit log is gone when ours is taken.
    if (parent >= 0) {
      pollfd p{parent, POLLIN, 0};
      while (poll(&p, 1, 10000) < 0 && errno == EINTR) {
      }
    }
    _exit(on_loss());
  }
  close(fds[0]);
  fd_ = fds[1];
  pid_ = pid;
}

Guardian::~Guardian() {
  if (fd_ < 0) return;
  const char word = 1;
  (void)!send(fd_, &word, 1, MSG_NOSIGNAL);
  close(fd_);
  while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
  }
}

}  // namespace contego::cli
