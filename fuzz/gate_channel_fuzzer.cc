// Fuzzes what the monitor reads from a client's shared-memory channel: the
// control words a hostile client may set to anything (type, claimed length)
// and the request payload. The monitor must refuse a length beyond the slot
// without reading it, and otherwise hand exactly the claimed bytes, copied,
// to the same decoders the socket path uses.
//
// Input: u32 type, u32 claimed length (both native order), then the bytes
// the client leaves in the request slot.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <sys/mman.h>
#include <vector>

#include "gate/channel.h"
#include "gate/wire.h"

using namespace contego::gate;

namespace {

struct Rig {
  std::unique_ptr<Channel> server;
  uint8_t* client_view = nullptr;  // the client's mapping of the same file
  uint32_t seq = 0;
};

Rig& rig() {
  static Rig* r = [] {
    auto* rg = new Rig;
    // No socket: a peer check would say "gone"; the requests never need one.
    auto s = Channel::create(-1, SpinPolicy{0, 1});
    if (!s.ok()) __builtin_trap();
    rg->server = std::move(*s);
    void* m =
        mmap(nullptr, Channel::kSize, PROT_READ | PROT_WRITE, MAP_SHARED, rg->server->memfd(), 0);
    if (m == MAP_FAILED) __builtin_trap();
    rg->client_view = static_cast<uint8_t*>(m);
    return rg;
  }();
  return *r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 8) return 0;
  Rig& r = rig();
  uint32_t type = 0, len = 0;
  std::memcpy(&type, data, 4);
  std::memcpy(&len, data + 4, 4);
  const size_t body = std::min(size - 8, Channel::kSlotSize);
  std::memcpy(r.client_view + Channel::kControlSize, data + 8, body);
  auto* control = reinterpret_cast<ChannelControl*>(r.client_view);
  control->request_type.store(type);
  control->request_len.store(len);
  control->request_seq.store(++r.seq);

  uint8_t got_type = 0;
  uint32_t claimed = 0;
  std::vector<uint8_t> payload;
  const Channel::Next next = r.server->next_request(&got_type, &claimed, &payload);
  if (claimed != len) __builtin_trap();
  if (len > Channel::kSlotSize) {
    if (next != Channel::Next::kOversized) __builtin_trap();
  } else {
    if (next != Channel::Next::kRequest || payload.size() != len) __builtin_trap();
    if (len <= body && std::memcmp(payload.data(), data + 8, len) != 0) __builtin_trap();
    Transfer t;
    if (wire::decode_transfer(payload, &t).ok()) (void)to_transactions(t);
    std::string task;
    (void)wire::decode_hello(payload, &task);
  }
  const std::vector<uint8_t> answer = {1, 2, 3};
  r.server->answer(static_cast<uint8_t>(wire::Type::kReply), answer);
  if (control->reply_seq.load() != r.seq) __builtin_trap();
  return 0;
}
