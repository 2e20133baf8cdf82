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
// Thread-safety: one thread per connection; stop() may be called from any thread.
#ifndef CONTEGO_MONITOR_SERVER_H_
#define CONTEGO_MONITOR_SERVER_H_

#include <atomic>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <sys/types.h>
#include <thread>
#include <vector>

#include "base/result.h"
#include "gate/channel.h"
#include "gate/wire.h"
#include "monitor/audit_log.h"
#include "monitor/monitor.h"

namespace contego::monitor {

class Server {
 public:
  // `tasks`: task name -> id. `allowed_uids`: peers whose uid may connect.
  Server(Monitor& monitor, AuditLog& audit, std::map<std::string, uint16_t> tasks,
         std::set<uid_t> allowed_uids, gate::SpinPolicy spin = {}, bool realtime = false);
  ~Server();
  Status listen(const std::string& path);  // replaces a stale socket file; mode 0660
  void serve();                            // accept loop; returns after stop()
  void stop();

 private:
  struct Session;
  void connection(int fd);
  std::optional<gate::wire::Type> dispatch(Session& s, uint8_t type,
                                           std::span<const uint8_t> payload, bool channel);
  void serve_channel(Session& s, gate::Channel& channel);
  Monitor& monitor_;
  AuditLog& audit_;
  std::map<std::string, uint16_t> tasks_;
  std::set<uid_t> allowed_;
  gate::SpinPolicy spin_;
  bool realtime_;  // serve each connection at its task's priority (SCHED_FIFO)
  int listen_fd_ = -1;
  std::string path_;
  std::atomic<bool> stopping_{false};
  std::mutex mu_;
  std::set<int> open_fds_;
  std::vector<std::thread> threads_;
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_SERVER_H_
