// The gate's wire protocol between an enclave client and a monitor process
// over a Unix stream socket. docs/gate-protocol.md is the normative text.
//
// Every message is a frame: a 12-byte header (magic "CG", version, type,
// sequence number, payload length, all little-endian) and a payload of at
// most kMaxPayload bytes. Decoding never trusts a length: every field is
// bounds-checked against the frame, and anything malformed is refused with a
// reason (the server answers kError and keeps serving).
#ifndef CONTEGO_GATE_WIRE_H_
#define CONTEGO_GATE_WIRE_H_

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "base/result.h"
#include "gate/transfer.h"

namespace contego::gate::wire {

inline constexpr uint16_t kMagic = 0x4743;  // "CG"
inline constexpr uint8_t kVersion = 1;
inline constexpr uint32_t kHeaderSize = 12;
inline constexpr uint32_t kMaxPayload = 512 * 1024;  // 42 messages of 8192 bytes fit
inline constexpr uint32_t kMaxTaskName = 64;

enum class Type : uint8_t {
  kHello = 1,      // client: task name [+ Vouch]       -> kHelloOk | kError
  kHelloOk = 2,    // server: task id and priority
  kTransfer = 3,   // client: a Transfer                -> kReply | kError
  kReply = 4,      // server: a TransferReply
  kJobEnd = 5,     // client: job boundary (no answer)
  kBusInfo = 6,    // client: bus number                -> kBusInfoOk | kError
  kBusInfoOk = 7,  // server: present flag and I2C_FUNCS
  kChannel = 8,    // client: empty; asks for a shared-memory channel -> kChannelOk | kError
  kChannelOk = 9,  // server: u32 channel size; the memfd rides along (SCM_RIGHTS)
  kJobEndOk = 10,  // server, channel only: the job-end was taken
  kReset = 11,     // operator: device name; clears its latch -> kResetOk | kError
  kResetOk = 12,   // server: u8 1 if the device was latched
  kRevouch = 13,   // supervisor: task name + Vouch, after the program's exec -> kRevouchOk | kError
  kRevouchOk = 14,  // server: empty; the new executable may act for the task
  kStatus = 15,     // operator: empty; the monitor's state  -> kStatusOk | kError
  kStatusOk = 16,   // server: JSON text (docs/deployment.md, "contego status")
  kReload = 17,     // operator: a policy bundle and its signature -> kReloadOk | kError
  kReloadOk = 18,   // server: what the reload kept and started afresh (text)
  kGoodbye = 19,    // client: its exit's wait status, as the process exits -> kGoodbyeOk
  kGoodbyeOk = 20,  // server: empty; the session's end is settled
  kError = 0x7F,    // server: errno and reason text
};

// Transfer flags, bit 3: the descriptor's own I2C_RETRIES and I2C_TIMEOUT
// follow the messages (gate::Timing). A monitor that predates it refuses
// such a transfer (unknown flags) rather than drop them unseen.
inline constexpr uint8_t kTransferOwnTiming = 8;

struct Header {
  uint16_t magic = kMagic;
  uint8_t version = kVersion;
  uint8_t type = 0;
  uint32_t seq = 0;
  uint32_t length = 0;  // payload bytes
};

// A contego supervisor's hello names the program it speaks for: the child's
// pid and the path that child executes (the monitor checks the task's
// binding against them; monitor/peer_identity.h).
struct Vouch {
  uint32_t pid = 0;  // 0 = no vouch: the peer speaks for itself
  std::string exe;   // absolute path, 1..4095 bytes
};

struct HelloOk {
  uint16_t task = 0;
  uint16_t priority = 0;  // the policy's task priority (larger = more important); 0 = none
};

struct BusInfo {
  bool present = false;
  uint64_t funcs = 0;
};

struct ErrorMsg {
  int32_t err = 0;
  std::string reason;
};

// Header: ok, or why it is refused (bad magic, version, type, length).
Status decode_header(std::span<const uint8_t> bytes, Header* out);
std::vector<uint8_t> frame(Type type, uint32_t seq, std::span<const uint8_t> payload);
// The 12 header bytes of a frame with `length` payload bytes.
void encode_header(Type type, uint32_t seq, uint32_t length, uint8_t out[kHeaderSize]);

std::vector<uint8_t> encode_hello(const std::string& task, const Vouch& vouch = {});
Status decode_hello(std::span<const uint8_t> payload, std::string* task, Vouch* vouch = nullptr);
std::vector<uint8_t> encode_hello_ok(const HelloOk& h);
Status decode_hello_ok(std::span<const uint8_t> payload, HelloOk* h);
std::vector<uint8_t> encode_transfer(const Transfer& t);
// The same into *out (cleared first): a reused buffer, no allocation once grown.
void encode_transfer(const Transfer& t, std::vector<uint8_t>* out);
Status decode_transfer(std::span<const uint8_t> payload, Transfer* t);
std::vector<uint8_t> encode_reply(const TransferReply& r);
void encode_reply(const TransferReply& r, std::vector<uint8_t>* out);
Status decode_reply(std::span<const uint8_t> payload, TransferReply* r);
std::vector<uint8_t> encode_bus_info(const BusInfo& b);
Status decode_bus_info(std::span<const uint8_t> payload, BusInfo* b);
std::vector<uint8_t> encode_error(const ErrorMsg& e);
Status decode_error(std::span<const uint8_t> payload, ErrorMsg* e);
// goodbye: the wait status the exiting process will have (0: exit(0)).
std::vector<uint8_t> encode_goodbye(int32_t wait_status);
Status decode_goodbye(std::span<const uint8_t> payload, int32_t* wait_status);

// `contego reload`: a policy bundle (contego check --emit-bundle) and its
// minisign signature (empty: none), as u32 length + bytes each.
struct ReloadRequest {
  std::string bundle;
  std::string signature;
};
std::vector<uint8_t> encode_reload(const ReloadRequest& r);
Status decode_reload(std::span<const uint8_t> payload, ReloadRequest* r);

}  // namespace contego::gate::wire

#endif  // CONTEGO_GATE_WIRE_H_
