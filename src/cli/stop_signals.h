// SIGINT, SIGTERM and SIGHUP, blocked for the whole process and readable from
// a signalfd: how `contego run`, `contego monitor` and `contego kmod audit`
// take their stop and reopen signals. Construct it before any thread starts
// (threads inherit the mask; one that does not block them dies of SIGTERM).
#ifndef CONTEGO_CLI_STOP_SIGNALS_H_
#define CONTEGO_CLI_STOP_SIGNALS_H_

#include <signal.h>
#include <unistd.h>

#include <sys/signalfd.h>

#include "base/unique_fd.h"

namespace contego::cli {

// `fd` is -1 if signalfd failed: then the signals are only blocked (sigwait
// on `set` still takes them).
struct StopSignals {
  sigset_t set{}, original{};
  base::UniqueFd fd;
  StopSignals() {
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &set, &original);
    fd.reset(signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK));
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;
  // The next signal taken (SIGTERM if none can be read).
  int which() const {
    signalfd_siginfo info{};
    if (fd.valid() && read(fd.get(), &info, sizeof info) == static_cast<ssize_t>(sizeof info)) {
      return static_cast<int>(info.ssi_signo);
    }
    return SIGTERM;
  }
};

}  // namespace contego::cli

#endif  // CONTEGO_CLI_STOP_SIGNALS_H_
