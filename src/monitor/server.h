// The monitor's Unix-socket server: authenticates each peer with SO_PEERCRED
// (its uid must be in the allowed set), binds the connection to the task it
// names in its hello, and serves transfers through the Monitor. A malformed
// or oversized message gets a kError answer; the server keeps serving (a
// connection whose framing is lost is closed; other connections go on).
// When a connection bound to a task closes, the task's actuators are driven
// to their safe state. A bound client may move its connection onto a
// shared-memory channel (gate/channel.h); the messages and answers are the
// same, only the transport changes. With `realtime`, the thread serving a
// connection runs under SCHED_FIFO at its task's policy priority.
//
// The server keeps serving whatever clients do: at most
// `max_per_uid` live connections per peer uid and `connects_per_second` new
// ones per uid and second (more are refused: a reconnect loop), a
// connection that has not said hello within `hello_timeout_ms` is closed, a
// failed accept() (EMFILE, ENFILE, ENOMEM...) backs off and retries (the
// connections already open go on), finished connection threads are joined.
// Client-error events (peer, peer-refused, malformed, hello-timeout,
// accept-failed) are rate-limited per peer uid: at most `events_per_second`
// are written each second, the rest counted into one `suppressed` summary
// per uid and second. Decisions are never suppressed.
//
// Who may run a task (set_bindings, from the policy's `user`, `group`,
// `exe`, `unit`, `cgroup`) is checked on hello against kernel facts about
// the peer (monitor/peer_identity.h), or about the program a contego
// supervisor vouches for; a mismatch is refused (EACCES) and audited
// (`hello-refused`). A task takes at most its `sessions` (default 1) live
// sessions; a further hello is refused and audited. A peer that is, or
// descends from, a program supervised for a live session of this monitor
// (or its supervisor) is refused whatever task it names: a supervised
// program has no channel of its own. A refused hello binds nothing, so its
// connection's end drives nothing safe; the end of a bound session drives
// the safe state of that task's actuators only (Monitor::task_exited).
//
// Thread-safety: one thread per connection; stop() may be called from any thread.
#ifndef CONTEGO_MONITOR_SERVER_H_
#define CONTEGO_MONITOR_SERVER_H_

#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <sys/types.h>
#include <thread>
#include <vector>

#include "base/mutex.h"
#include "base/result.h"
#include "base/unique_fd.h"
#include "gate/channel.h"
#include "gate/wire.h"
#include "monitor/audit_log.h"
#include "monitor/monitor.h"
#include "monitor/peer_identity.h"

namespace contego::monitor {

struct ServerLimits {
  uint32_t max_per_uid = 32;           // live connections per peer uid (0 = no cap)
  uint32_t hello_timeout_ms = 2000;    // a connection must say hello within this (0 = never)
  uint32_t events_per_second = 20;     // client-error events written per uid and second
  uint32_t connects_per_second = 100;  // new connections per uid and second (0 = no limit)
};

class Server {
 public:
  // `tasks`: task name -> id. `allowed_uids`: peers whose uid may connect.
  Server(Monitor& monitor, AuditLog& audit, std::map<std::string, uint16_t> tasks,
         std::set<uid_t> allowed_uids, gate::SpinPolicy spin = {}, bool realtime = false,
         ServerLimits limits = {});
  ~Server();
  // Who may run each task, by name (a task not named: anyone allowed to
  // connect, one session). Call before serve().
  void set_bindings(std::map<std::string, TaskBinding> bindings) {
    base::MutexLock lock(mu_);
    bindings_ = std::move(bindings);
  }
  Status listen(const std::string& path);  // replaces a stale socket file; mode 0660
  // A second, read-only socket: it answers `contego status` and nothing
  // else, to root, the monitor's uid and members of the status group (the
  // peer's primary or supplementary groups as SO_PEERCRED/SO_PEERGROUPS give
  // them); anyone else who can reach it gets the refusal's reason. Optional;
  // call after listen().
  Status listen_status(const std::string& path);
  // The group whose members may read the status (on either socket; on the
  // main socket only if their uid may connect at all). Call before serve().
  void set_status_group(gid_t group) { status_group_ = group; }
  void serve();  // accept loop; returns after stop()
  void stop();
  // Counters (tests): connections refused over the cap, closed for no
  // hello, failed accepts, events suppressed by the rate limit.
  uint64_t refused_over_cap() const { return over_cap_.load(); }
  uint64_t hello_timeouts() const { return hello_timeouts_.load(); }
  uint64_t accept_failures() const { return accept_failures_.load(); }
  uint64_t events_suppressed() const { return suppressed_total_.load(); }
  uint64_t hellos_refused() const { return hellos_refused_.load(); }
  uint64_t refused_over_rate() const { return over_rate_.load(); }
  size_t live_connections();

 private:
  // One connection's state and its answers, the same whether a message came
  // over the socket or through the shared-memory channel.
  struct Conn;
  struct Session {
    Conn* conn = nullptr;
    bool bound = false;
    uint16_t task = 0;
    pid_t vouched = 0;      // the supervised program's pid (a supervisor's session)
    std::string task_name;  // as the hello named it
    pid_t group = 0;        // the peer's process group at its hello
    // Its process said it exits cleanly (the preload client's goodbye)
    // inside a group whose leader lived then: the session goes on with that
    // leader (handed_), and its connection's end ends nothing. Unset:
    // killed, crashed, failing, the group's leader itself, or a client
    // that does not say.
    bool handed = false;
    gate::Transfer transfer;  // reused: no allocation per exchange once grown
    std::vector<uint8_t> out;
  };
  struct Conn {
    base::UniqueFd fd;
    uid_t uid = 0;
    pid_t pid = 0;
    base::UniqueFd pidfd;            // pins the peer (SO_PEERPIDFD or pidfd_open)
    uint64_t hello_deadline_us = 0;  // 0: said hello (or no timeout)
    std::atomic<bool> hello{false};
    std::atomic<bool> done{false};
    bool read_only = false;     // came in on the status socket: status requests only
    bool status_group = false;  // the peer is in the status group
    // Server::mu_ (the analysis cannot name an enclosing object's lock here)
    bool timed_out = false;
    int task = -1;  // the task its session is bound to, -1 none; Server::mu_
    std::thread thread;
  };
  struct EventBudget {
    uint64_t window_us = 0;
    uint32_t written = 0;
    uint64_t suppressed = 0;
  };
  void connection(Conn* c);
  struct AcceptReports {  // failed accepts: one event per second at most
    uint64_t reported_us = 0, unreported = 0;
  };
  // Accepts one peer on `listener` (the status socket if `read_only`).
  void accept_one(int listener, bool read_only, AcceptReports* reports);
  // A client-error event, rate-limited per uid.
  void client_event(uid_t uid, const std::string& kind, const std::string& detail);
  // Refuses a connecting peer: a `peer-refused` event ("pid P uid U" and
  // `why`), then an error frame of `error` and `message` on `fd`.
  void refuse_peer(int fd, pid_t pid, uid_t uid, const std::string& why, int error,
                   const char* message);
  void flush_suppressed(bool all);  // summaries of windows that are over
  // Joins finished threads, enforces hello deadlines, writes the counts of
  // ended event windows; returns the poll timeout (ms, -1: none) until the
  // next of these is due, so that an idle monitor sleeps.
  int housekeeping();
  void wake();  // the accept loop runs housekeeping() again now
  std::optional<gate::wire::Type> dispatch(Session& s, uint8_t type,
                                           std::span<const uint8_t> payload, bool channel);
  gate::wire::Type reset(Session& s, std::span<const uint8_t> payload);  // `contego reset`
  void serve_channel(Session& s, gate::Channel& channel);
  // Binds the session to `task` if the peer may run it; else the reason.
  Status admit(Session& s, const std::string& name, uint16_t task, const gate::wire::Vouch& vouch);
  Status identity_refusal(const Conn& c, const std::string& name, const gate::wire::Vouch& vouch);
  bool descends_from_supervised(pid_t pid) REQUIRES(mu_);
  // Task `name`'s id and binding (none: anyone allowed to connect, one
  // session) as the policy says now: copies, taken under mu_.
  std::optional<uint16_t> task_of(const std::string& name) EXCLUDES(mu_) {
    base::MutexLock lock(mu_);
    const auto it = tasks_.find(name);
    return it == tasks_.end() ? std::nullopt : std::optional<uint16_t>(it->second);
  }
  std::optional<TaskBinding> binding_of(const std::string& name) EXCLUDES(mu_) {
    base::MutexLock lock(mu_);
    const auto it = bindings_.find(name);
    return it == bindings_.end() ? std::nullopt : std::optional<TaskBinding>(it->second);
  }
  // The peer rules for every message but hello (ok when it may be answered).
  Status message_refusal(const Session& s, gate::wire::Type type);
  // A supervisor's re-vouch after its program's exec (ok: it may go on).
  Status revouch_refusal(const Session& s, pid_t pid);
  gate::wire::Type revouch(Session& s, std::span<const uint8_t> payload);
  gate::wire::Type status(Session& s);  // `contego status` (server_status.cc)
  gate::wire::Type reload(Session& s, std::span<const uint8_t> payload);  // server_reload.cc
 public:
  // What the status answer names the running policy by (its source and
  // image SHA-256), set once before serve().
  void set_policy_source(std::string source, std::string image_sha256 = {}) {
    base::MutexLock lock(mu_);
    policy_source_ = std::move(source);
    image_sha256_ = std::move(image_sha256);
  }
  // `contego reload`: the daemon's hook that verifies and loads a new policy
  // (this library knows no bundles nor signatures). It gets the request and
  // the peer's uid once the peer may reload (root or the monitor's uid, not
  // a task's session nor a supervised program), and answers with the text
  // for the operator or an errno and reason. A refusal is audited
  // (`reload-refused`). Unset: reloads are refused (ENOTSUP).
  struct ReloadAnswer {
    int err = 0;
    std::string text;
  };
  using Reloader = std::function<ReloadAnswer(const gate::wire::ReloadRequest&, uid_t)>;
  void set_reloader(Reloader reloader) { reloader_ = std::move(reloader); }
  // The reloader's last step, once the new policy is verified and loaded:
  // under the server's lock (no hello, no session end meanwhile) it checks
  // that every task with a live session keeps its name and id in `tasks`,
  // then runs `monitor_reload` (Monitor::reload) and, if that succeeds,
  // serves the new tasks, bindings and source.
  Result<std::string> apply_reload(std::map<std::string, uint16_t> tasks,
                                   std::map<std::string, TaskBinding> bindings, std::string source,
                                   std::string image_sha256,
                                   const std::function<Result<std::string>()>& monitor_reload);

  // contego-monitor serves `contego run`, another executable installed
  // beside it: its vouches for a program's `exe` are taken as the monitor's
  // own would be. Fails if `path` cannot be stat'ed (the caller says so).
  bool trust_supervisor(const std::string& path);
  // The monitor's state as `contego status --json` shows it (and the
  // metrics file is made of): the monitor's, the sessions, the audit log.
  std::string status_json();

 private:
  std::string policy_source_ GUARDED_BY(mu_);  // a reload replaces it
  std::string image_sha256_ GUARDED_BY(mu_);
  Reloader reloader_;  // set before serve()
  const uint64_t started_us_ = monotonic_us();
  // Whether a bound session of `task` (with `pid`: any of that peer's) has a
  // peer that hung up: its connection's thread has yet to notice and end it.
  bool session_ending(int task, pid_t pid) const REQUIRES(mu_);
  void end_session(Session& s);
  Monitor& monitor_;
  AuditLog& audit_;
  std::map<std::string, uint16_t> tasks_ GUARDED_BY(mu_);  // a reload replaces it
  std::set<uid_t> allowed_;
  gate::SpinPolicy spin_;
  bool realtime_;  // serve each connection at its task's priority (SCHED_FIFO)
  base::UniqueFd listen_fd_;
  base::UniqueFd wake_fd_;  // an eventfd: a connection ended, an event window began, stop()
  std::string path_;
  base::UniqueFd status_fd_;  // the read-only status socket, if any
  std::string status_path_;
  std::optional<gid_t> status_group_;
  std::atomic<bool> stopping_{false};
  ServerLimits limits_;
  base::Mutex mu_;
  std::vector<std::unique_ptr<Conn>> conns_ GUARDED_BY(mu_);
  std::map<uid_t, uint32_t> per_uid_ GUARDED_BY(mu_);  // live connections
  // New connections per uid in the current second (the accept loop's only).
  std::map<uid_t, std::pair<uint64_t, uint32_t>> connects_;
  std::map<std::string, TaskBinding> bindings_ GUARDED_BY(mu_);  // a reload replaces it
  std::map<uint16_t, uint32_t> live_sessions_ GUARDED_BY(mu_);   // per task, handed ones too
  // Sessions whose process exited cleanly inside a process group whose
  // leader lives (a script's i2cset): they end when that leader exits
  // (contego/session_room.h), as under contego.ko.
  struct HandedSession {
    uint16_t task = 0;
    pid_t leader = 0;
    base::UniqueFd leader_fd;  // a pidfd: readable once the leader has exited
  };
  std::vector<HandedSession> handed_ GUARDED_BY(mu_);
  // Ends the handed sessions whose leader exited; true while any is left.
  bool end_handed_sessions();
  // The goodbye of the session's process (its exit's wait status).
  void goodbye(Session& s, int32_t wait_status);
  std::condition_variable session_ended_;            // a session ended; with mu_
  std::multiset<pid_t> supervised_ GUARDED_BY(mu_);  // live supervisors and their programs
  // The executables whose word on a program's `exe` is taken: this one, and
  // the supervisor trusted with trust_supervisor() (device, inode).
  std::vector<std::pair<dev_t, ino_t>> supervisors_;
  base::Mutex events_mu_;
  std::map<uid_t, EventBudget> budgets_ GUARDED_BY(events_mu_);
  std::atomic<uint64_t> over_cap_{0}, hello_timeouts_{0}, accept_failures_{0}, suppressed_total_{0},
      hellos_refused_{0}, over_rate_{0};
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_SERVER_H_
