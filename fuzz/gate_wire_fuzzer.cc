// Fuzzes the gate protocol decoders the monitor runs on bytes from a peer:
// header, then the payload as every message type. Anything decoded must
// re-encode to the same bytes (the codec is canonical).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "gate/wire.h"

using namespace contego::gate;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::span<const uint8_t> in(data, size);
  if (size >= wire::kHeaderSize) {
    wire::Header h;
    (void)wire::decode_header(in.first(wire::kHeaderSize), &h);
    in = in.subspan(wire::kHeaderSize);
  }
  Transfer t;
  if (wire::decode_transfer(in, &t).ok()) {
    const auto again = wire::encode_transfer(t);
    if (again.size() != in.size() || !std::equal(again.begin(), again.end(), in.begin())) {
      __builtin_trap();
    }
    (void)to_transactions(t);
  }
  TransferReply r;
  if (wire::decode_reply(in, &r).ok()) {
    const auto again = wire::encode_reply(r);
    if (again.size() != in.size()) __builtin_trap();
  }
  std::string task;
  (void)wire::decode_hello(in, &task);
  wire::BusInfo b;
  (void)wire::decode_bus_info(in, &b);
  wire::ErrorMsg e;
  (void)wire::decode_error(in, &e);
  wire::ReloadRequest reload;
  if (wire::decode_reload(in, &reload).ok()) {
    const auto again = wire::encode_reload(reload);
    if (again.size() != in.size() || !std::equal(again.begin(), again.end(), in.begin())) {
      __builtin_trap();
    }
  }
  if (int32_t status = 0;
      wire::decode_goodbye(in, &status).ok() && wire::encode_goodbye(status).size() != in.size()) {
    __builtin_trap();
  }
  wire::HelloOk ok;
  if (wire::decode_hello_ok(in, &ok).ok() && wire::encode_hello_ok(ok).size() != in.size()) {
    __builtin_trap();
  }
  return 0;
}
