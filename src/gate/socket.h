// Unix-socket transport of the gate protocol: the framing the monitor's
// server and its clients (gate/socket_client.h) share.
#ifndef CONTEGO_GATE_SOCKET_H_
#define CONTEGO_GATE_SOCKET_H_

#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "base/mutex.h"
#include "base/result.h"
#include "base/unique_fd.h"
#include "gate/channel.h"
#include "gate/endpoint.h"
#include "gate/wire.h"

namespace contego::gate {

// A stream socket connected to the monitor listening at `path`.
Result<base::UniqueFd> connect_to_monitor(const std::string& path);

// Writes one frame completely. False on any error.
bool send_frame(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload);
// Reads one frame with two recv calls (never reads past it), or says why
// not ("closed" at end of stream). A header the decoder refuses is
// reported and the stream is unusable.
Status recv_frame(int fd, wire::Header* header, std::vector<uint8_t>* payload);

// Buffered frame reader for one connection: one recv() per frame in the
// usual case (it asks for as much as the buffer holds and keeps bytes that
// belong to the next frame), no allocation once the buffer has grown to the
// largest frame seen. Same results as recv_frame.
// What FrameReader::next found: a frame, the peer's end between frames, or
// lost framing (`why` says how; "closed" for the peer's end).
struct FrameStatus {
  enum class Kind : uint8_t { kFrame, kClosed, kBroken };
  Kind kind = Kind::kFrame;
  std::string why;
  bool ok() const { return kind == Kind::kFrame; }
};

class FrameReader {
 public:
  explicit FrameReader(int fd);
  // *payload stays valid until the next call.
  FrameStatus next(wire::Header* header, std::span<const uint8_t>* payload);

 private:
  static constexpr size_t kInitialCapacity = 16 * 1024;
  int fd_;
  std::vector<uint8_t> buf_;
  size_t start_ = 0, end_ = 0;  // unconsumed bytes are buf_[start_, end_)
  size_t consumed_ = 0;         // bytes of the frame handed out last
};

}  // namespace contego::gate

#endif  // CONTEGO_GATE_SOCKET_H_
