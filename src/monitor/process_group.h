// The process facts the session rules both clients share take
// (contego/session_room.h), as the monitor reads them from the kernel: a
// peer's process group, whether its leader lives, the peer's unit.
#ifndef CONTEGO_MONITOR_PROCESS_GROUP_H_
#define CONTEGO_MONITOR_PROCESS_GROUP_H_

#include <sys/types.h>

namespace contego::monitor {

// Whether the process `pid` is still running (a zombie has exited).
bool process_lives(pid_t pid);
// Whether `group` is a process group whose leader lives: the process of that
// pid runs and leads the group. False for 0 (no group: init's).
bool group_leader_lives(pid_t group);
// The process group of `pid`; 0 when it cannot be read (the process is gone).
pid_t group_of(pid_t pid);
// The session unit of the live process `pid` (contego_session_unit): its
// group when it is not the group's leader and the leader lives; itself
// otherwise. 0: the process has exited.
pid_t session_unit(pid_t pid);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_PROCESS_GROUP_H_
