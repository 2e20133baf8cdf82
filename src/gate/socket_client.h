// SocketClient: the Endpoint an enclave client uses to reach a separate
// monitor process over its Unix socket (gate/socket.h's framing), and the
// shared-memory channel it then asks for. It fails closed: once the
// connection is lost every transfer answers EIO and nothing is performed.
// Client side only: the monitor does not link it.
#ifndef CONTEGO_GATE_SOCKET_CLIENT_H_
#define CONTEGO_GATE_SOCKET_CLIENT_H_

#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <sys/types.h>

#include "base/mutex.h"
#include "base/result.h"
#include "gate/channel.h"
#include "gate/endpoint.h"
#include "gate/socket.h"
#include "gate/wire.h"

namespace contego::gate {

class SocketClient final : public Endpoint {
 public:
  // Connects to the monitor at `path` and announces `task` (its name in the
  // policy). With `channel`, it then asks for a shared-memory channel and
  // uses it for every later exchange (the socket otherwise, e.g. if the
  // monitor refuses). A contego supervisor passes `vouch`: the program it
  // speaks for (wire::Vouch).
  static Result<std::unique_ptr<SocketClient>> connect(
      const std::string& path, const std::string& task,
      std::optional<SpinPolicy> channel = SpinPolicy{}, const wire::Vouch& vouch = {});
  ~SocketClient() override;
  uint16_t task_id() const { return task_id_; }
  uint16_t task_priority() const { return task_priority_; }  // from the policy; 0 = none
  bool uses_channel() const { return channel_ != nullptr; }
  // Waits up to `timeout_ms` for the monitor to close the connection (it
  // stopped or died); true once it has. Safe beside transfers: it only polls.
  bool wait_closed(int timeout_ms) const;

  TransferReply transfer(uint16_t task, const Transfer& transfer) override;
  void job_boundary(uint16_t task) override;
  void task_exited(uint16_t task) override;
  // As the process exits (the preload client's on_exit hook): the wait
  // status it will have. Awaited, so that the monitor settles the session's
  // end while the process's parent still waits for it; the connection stays
  // usable for what later exit handlers send. The monitor hands the session
  // of a process that exits cleanly in a script to the script
  // (contego/session_room.h).
  void goodbye(int32_t wait_status);
  bool has_bus(uint8_t bus) override;
  // After a supervised process (pid) called execve: asks the monitor to
  // check the task's binding against what it now executes: ok when it may
  // go on acting for the task, else why not (the connection unusable too).
  Status revouch(pid_t pid, const std::string& task);
  uint64_t funcs(uint8_t bus) override;

 private:
  explicit SocketClient(int fd) : fd_(fd), reader_(fd) {}
  // One request/answer exchange; false if the connection is unusable.
  // *answer is valid until the next exchange.
  bool exchange(wire::Type type, std::span<const uint8_t> payload, wire::Header* h,
                std::span<const uint8_t>* answer) REQUIRES(mu_);
  wire::BusInfo bus_info(uint8_t bus) EXCLUDES(mu_);
  void open_channel(SpinPolicy policy) REQUIRES(mu_);
  // One exchange at a time on the connection (and its channel).
  base::Mutex mu_;
  int fd_;
  FrameReader reader_ GUARDED_BY(mu_);
  std::vector<uint8_t> out_ GUARDED_BY(mu_);  // reused: the encoded transfer
  bool broken_ GUARDED_BY(mu_) = false;
  uint32_t seq_ GUARDED_BY(mu_) = 0;
  uint16_t task_id_ = 0;        // set by connect(), then read only
  uint16_t task_priority_ = 0;  // set by connect(), then read only
  std::map<uint8_t, wire::BusInfo> buses_ GUARDED_BY(mu_);
  // Set by connect() (before the client is shared), then used under mu_.
  std::unique_ptr<Channel> channel_ PT_GUARDED_BY(mu_);
};

}  // namespace contego::gate

#endif  // CONTEGO_GATE_SOCKET_CLIENT_H_
