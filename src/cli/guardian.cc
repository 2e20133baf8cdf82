#include "cli/guardian.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace contego::cli {

Guardian::Guardian(const std::function<int()>& on_loss, std::string* error) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    *error = std::string("pipe: ") + strerror(errno);
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
    char word = 0;
    ssize_t n;
    do {
      n = read(fds[0], &word, 1);
    } while (n < 0 && errno == EINTR);
    if (n == 1) _exit(0);  // released: the supervisor ended cleanly
    _exit(on_loss());
  }
  close(fds[0]);
  fd_ = fds[1];
  pid_ = pid;
}

Guardian::~Guardian() {
  if (fd_ < 0) return;
  const char word = 1;
  (void)!write(fd_, &word, 1);
  close(fd_);
  while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
  }
}

}  // namespace contego::cli
