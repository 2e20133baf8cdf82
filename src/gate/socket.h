// Unix-socket transport of the gate protocol: framing helpers shared by the
// monitor's server, and SocketClient, the Endpoint an enclave client uses to
// reach a separate monitor process. SocketClient fails closed: once the
// connection is lost every transfer answers EIO and nothing is performed.
#ifndef CONTEGO_GATE_SOCKET_H_
#define CONTEGO_GATE_SOCKET_H_

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "base/result.h"
#include "gate/endpoint.h"
#include "gate/wire.h"

namespace contego::gate {

// Writes one frame completely. False on any error.
bool send_frame(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload);
// Reads one frame. Returns "" or why not ("closed" at end of stream).
// A header the decoder refuses is reported and the stream is unusable.
std::string recv_frame(int fd, wire::Header* header, std::vector<uint8_t>* payload);

class SocketClient final : public Endpoint {
 public:
  // Connects to the monitor at `path` and announces `task` (its name in the policy).
  static Result<std::unique_ptr<SocketClient>> connect(const std::string& path,
                                                       const std::string& task);
  ~SocketClient() override;
  uint16_t task_id() const { return task_id_; }

  TransferReply transfer(uint16_t task, const Transfer& transfer) override;
  void job_boundary(uint16_t task) override;
  void task_exited(uint16_t task) override;
  bool has_bus(uint8_t bus) override;
  uint64_t funcs(uint8_t bus) override;

 private:
  explicit SocketClient(int fd) : fd_(fd) {}
  // One request/answer exchange; false if the connection is unusable.
  bool exchange(wire::Type type, const std::vector<uint8_t>& payload, wire::Header* h,
                std::vector<uint8_t>* answer);
  wire::BusInfo bus_info(uint8_t bus);
  std::mutex mu_;
  int fd_;
  bool broken_ = false;
  uint32_t seq_ = 0;
  uint16_t task_id_ = 0;
  std::map<uint8_t, wire::BusInfo> buses_;
};

}  // namespace contego::gate

#endif  // CONTEGO_GATE_SOCKET_H_
