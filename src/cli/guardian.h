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
#include <memory>
#include <sys/types.h>

#include "base/result.h"
#include "base/unique_fd.h"

namespace contego::cli {

class Guardian {
 public:
  // Forks the guardian; on failure, why there is none.
  static Result<std::unique_ptr<Guardian>> start(const std::function<int()>& on_loss);
  ~Guardian();  // a clean end: the guardian exits without acting
  Guardian(const Guardian&) = delete;
  Guardian& operator=(const Guardian&) = delete;

 private:
  Guardian(base::UniqueFd fd, pid_t pid) : fd_(std::move(fd)), pid_(pid) {}
  base::UniqueFd fd_;
  pid_t pid_ = -1;
};

}  // namespace contego::cli

#endif  // CONTEGO_CLI_GUARDIAN_H_
