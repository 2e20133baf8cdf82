// The guardian of `contego run`'s embedded monitor. The monitor lives in the
// supervisor's process, so if that process is killed (SIGKILL, a crash) no
// one would drive the safe state. The guardian is a process forked before the
// monitor starts (so it shares no thread, lock or descriptor with it but a
// socket) that waits for the supervisor's end: a clean end releases it; any
// other end (the socket closes without a word) runs `on_loss` in the guardian,
// which starts a monitor of its own and drives every actuator safe.
#ifndef CONTEGO_CLI_GUARDIAN_H_
#define CONTEGO_CLI_GUARDIAN_H_

#include <functional>
#include <string>
#include <sys/types.h>

namespace contego::cli {

class Guardian {
 public:
  // Forks the guardian. On failure the guardian is absent and *error says why.
  Guardian(const std::function<int()>& on_loss, std::string* error);
  ~Guardian();  // a clean end: the guardian exits without acting
  Guardian(const Guardian&) = delete;
  Guardian& operator=(const Guardian&) = delete;

 private:
  int fd_ = -1;
  pid_t pid_ = -1;
};

}  // namespace contego::cli

#endif  // CONTEGO_CLI_GUARDIAN_H_
