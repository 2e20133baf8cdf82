// Who a peer of the monitor is, from kernel facts, and whether it may run a
// task (issue 11, part 1).
//
// A policy binds a task to who may run it: `user`, `group` (name or numeric
// id), `exe` (a path, compared by device and inode), `unit` (a systemd unit:
// a component of the process's cgroup path) and/or `cgroup` (that path or
// one below it). The monitor resolves the names once at start
// (resolve_binding) and, on each hello, compares the binding with facts it
// reads itself: the uid/gid of SO_PEERCRED, the process pinned by a pidfd
// (SO_PEERPIDFD, else pidfd_open of the SO_PEERCRED pid), its
// /proc/PID/exe, /proc/PID/status and /proc/PID/cgroup, read after pinning
// and accepted only if the pidfd still names a live process afterwards (so
// the files belonged to that process, not to a later one with its number).
//
// A supervised program (`contego run --socket`) is vouched for by its
// supervisor: the hello names the child it supervises and the path that
// child will execute; the child must be a child of the peer (PPid) and the
// peer's uid must be root or the child's; the binding is checked against the
// child's uid, gid, groups and cgroup, and against the named path only if the
// peer is a contego supervisor (its exe is the monitor's own binary, same
// device and inode) — see Server::identity_refusal.
#ifndef CONTEGO_MONITOR_PEER_IDENTITY_H_
#define CONTEGO_MONITOR_PEER_IDENTITY_H_

#include <cstdint>
#include <optional>
#include <string>
#include <sys/types.h>
#include <vector>

#include "base/result.h"

namespace contego::monitor {

// The policy's words for who may run a task.
struct TaskIdentity {
  std::string exe, user, group, unit, cgroup;
  uint32_t sessions = 1;
};

// A task binding resolved on this host.
struct TaskBinding {
  std::optional<uid_t> uid;
  std::optional<gid_t> gid;
  std::string exe;  // the declared path (for messages)
  bool has_exe = false;
  dev_t exe_dev = 0;
  ino_t exe_ino = 0;
  std::string unit, cgroup;
  uint32_t sessions = 1;
  // Why the binding cannot be met on this host (an unknown user or group, an
  // exe that does not exist): every hello for the task is refused with it.
  std::string unresolved;
  bool binds() const {
    return uid || gid || has_exe || !unit.empty() || !cgroup.empty() || !unresolved.empty();
  }
};

// Names resolved with the host's user and group databases; the exe stat'ed.
// A binding that cannot be met on this host (unknown user or group, missing
// exe) is returned with `unresolved` set (that task is refused: fail closed;
// the others run); a malformed one (a relative exe or cgroup path) is an
// error naming the task.
Result<TaskBinding> resolve_binding(const std::string& task, const TaskIdentity& identity);

// What the kernel says about a process.
struct PeerFacts {
  pid_t pid = 0;
  pid_t ppid = 0;
  uid_t uid = 0;  // effective
  gid_t gid = 0;  // effective
  std::vector<gid_t> groups;
  bool exe_known = false;  // /proc/PID/exe could be read
  dev_t exe_dev = 0;
  ino_t exe_ino = 0;
  std::string exe_path;
  std::string cgroup;  // the unified-hierarchy path ("0::" line), else the systemd one
};

// Reads the facts of the process `pidfd` refers to (`pid` is its number).
// Fails if the process is gone or exits while being read.
Result<PeerFacts> process_facts(int pidfd, pid_t pid);
// A pidfd for the peer of a connected Unix socket: SO_PEERPIDFD where the
// kernel has it (the very process that connected), else pidfd_open of the
// SO_PEERCRED pid. -1 with errno on failure.
int peer_pidfd(int socket_fd, pid_t peer_pid);
// This process's own executable (device, inode), to recognise a contego supervisor.
bool own_exe(dev_t* dev, ino_t* ino);

// Why `facts` cannot run the task bound by `b` (ok: it may). `task` names
// the task in the reason.
Status binding_mismatch(const std::string& task, const TaskBinding& b, const PeerFacts& facts);

// The parsed /proc/PID/status and /proc/PID/cgroup fields (unit tests).
void parse_status(const std::string& status, PeerFacts* facts);
std::string unified_cgroup(const std::string& proc_cgroup);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_PEER_IDENTITY_H_
