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

Result<std::unique_ptr<Guardian>> Guardian::start(const std::function<int()>& on_loss) {
  // A socket pair, not a pipe: the release is sent with MSG_NOSIGNAL, so a
  // guardian killed meanwhile (by a program under the same uid) costs no SIGPIPE.
  int fds[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
    return make_error(std::string("socketpair: ") + strerror(errno));
  }
  base::UniqueFd guardian_end(fds[0]), supervisor_end(fds[1]);
  const pid_t pid = fork();
  if (pid < 0) return make_error(std::string("fork: ") + strerror(errno));
  if (pid == 0) {
    supervisor_end.reset();
    // Not traceable by the program (which runs under the same uid unless
    // told otherwise); SIGINT/SIGTERM/SIGHUP stay blocked as in the parent.
    (void)prctl(PR_SET_DUMPABLE, 0, 0, 0, 0);
    (void)prctl(PR_SET_NAME, "contego-guard", 0, 0, 0);
    const int parent = static_cast<int>(syscall(SYS_pidfd_open, getppid(), 0));
    char word = 0;
    ssize_t n;
    do {
      n = read(guardian_end.get(), &word, 1);
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
  return std::unique_ptr<Guardian>(new Guardian(std::move(supervisor_end), pid));
}

Guardian::~Guardian() {
  const char word = 1;
  (void)!send(fd_.get(), &word, 1, MSG_NOSIGNAL);
  fd_.reset();
  while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
  }
}

}  // namespace contego::cli
