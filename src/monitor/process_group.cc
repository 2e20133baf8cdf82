// The process facts of contego/session_room.h's rules, read from the kernel.
#include "monitor/process_group.h"

#include <poll.h>
#include <unistd.h>

#include <cstdint>
#include <sys/syscall.h>

#include "contego/session_room.h"

#include "base/unique_fd.h"

namespace contego::monitor {

bool process_lives(pid_t pid) {
  if (pid <= 0) return false;
  // A pidfd polls readable once every thread of the process has exited,
  // zombie or reaped; a pid that cannot be opened is gone.
  const base::UniqueFd fd(static_cast<int>(syscall(SYS_pidfd_open, pid, 0)));
  if (!fd.valid()) return false;
  pollfd p{fd.get(), POLLIN, 0};
  return poll(&p, 1, 0) == 0;
}

bool group_leader_lives(pid_t group) {
  // The pid leads its group still (not a later process given a freed pid).
  return group > 0 && process_lives(group) && getpgid(group) == group;
}

pid_t group_of(pid_t pid) {
  const pid_t g = pid > 0 ? getpgid(pid) : -1;
  return g < 0 ? 0 : g;
}

pid_t session_unit(pid_t pid) {
  if (!process_lives(pid)) return 0;
  const pid_t group = group_of(pid);
  return static_cast<pid_t>(contego_session_unit(static_cast<uintptr_t>(pid),
                                                 static_cast<uintptr_t>(group),
                                                 group_leader_lives(group) ? 1 : 0));
}

}  // namespace contego::monitor
