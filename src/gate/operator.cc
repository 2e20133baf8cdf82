#include "gate/operator.h"

#include "gate/socket.h"
#include "gate/wire.h"

namespace contego::gate {

Result<bool> request_reset(const std::string& socket_path, const std::string& device) {
  if (device.empty() || device.size() > wire::kMaxTaskName) {
    return make_error("a device name of 1..64 characters expected");
  }
  auto connected = connect_to_monitor(socket_path);
  if (!connected) return make_error(connected.error());
  const int fd = connected->get();
  // Read even when the send failed: a refusal at accept may already be queued.
  const bool sent = send_frame(fd, wire::Type::kReset, 1, wire::encode_hello(device));
  FrameReader reader(fd);
  wire::Header h;
  std::span<const uint8_t> answer;
  if (const FrameStatus got = reader.next(&h, &answer); !got.ok()) {
    if (!sent) return make_error("the monitor at " + socket_path + " closed the connection");
    return make_error("no answer from the monitor at " + socket_path + ": " + got.why);
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kError)) {
    wire::ErrorMsg e;
    (void)wire::decode_error(answer, &e);
    return make_error("the monitor refused: " + e.reason);
  }
  if (h.type != static_cast<uint8_t>(wire::Type::kResetOk) || answer.size() != 1) {
    return make_error("unexpected answer from the monitor at " + socket_path);
  }
  return answer[0] != 0;
}

namespace {

// One request and its text answer of type `ok`.
Result<std::string> text_exchange(const std::string& socket_path, wire::Type type,
                                  std::span<const uint8_t> payload, wire::Type ok) {
  auto connected = connect_to_monitor(socket_path);
  if (!connected) return make_error(connected.error());
  const int fd = connected->get();
  const bool sent = send_frame(fd, type, 1, payload);  // read anyway, as request_reset
  FrameReader reader(fd);
  wire::Header h;
  std::span<const uint8_t> answer;
  if (const FrameStatus got = reader.next(&h, &answer); !got.ok()) {
    if (!sent) return make_error("the monitor at " + socket_path + " closed the connection");
    return make_error("no answer from the monitor at " + socket_path + ": " + got.why);
  }
  if (h.type == static_cast<uint8_t>(wire::Type::kError)) {
    wire::ErrorMsg e;
    (void)wire::decode_error(answer, &e);
    return make_error("the monitor refused: " + e.reason);
  }
  if (h.type != static_cast<uint8_t>(ok)) {
    return make_error("unexpected answer from the monitor at " + socket_path);
  }
  return std::string(answer.begin(), answer.end());
}

}  // namespace

Result<std::string> request_status(const std::string& socket_path) {
  return text_exchange(socket_path, wire::Type::kStatus, {}, wire::Type::kStatusOk);
}

Result<std::string> request_reload(const std::string& socket_path, const std::string& bundle,
                                   const std::string& signature) {
  const std::vector<uint8_t> payload = wire::encode_reload({bundle, signature});
  if (payload.size() > wire::kMaxPayload) {
    return make_error("the bundle and its signature (" + std::to_string(payload.size()) +
                      " bytes) exceed the monitor's " + std::to_string(wire::kMaxPayload) +
                      " byte message");
  }
  return text_exchange(socket_path, wire::Type::kReload, payload, wire::Type::kReloadOk);
}

}  // namespace contego::gate
