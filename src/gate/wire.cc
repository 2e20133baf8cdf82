#include "gate/wire.h"

#include <algorithm>
#include <cstring>

namespace contego::gate::wire {
namespace {

class Writer {
 public:
  Writer() : out(own_) {}
  explicit Writer(std::vector<uint8_t>& into) : out(into) { out.clear(); }
  void u8(uint8_t v) { out.push_back(v); }
  void u16(uint16_t v) {
    u8(static_cast<uint8_t>(v));
    u8(static_cast<uint8_t>(v >> 8));
  }
  void u32(uint32_t v) {
    u16(static_cast<uint16_t>(v));
    u16(static_cast<uint16_t>(v >> 16));
  }
  void u64(uint64_t v) {
    u32(static_cast<uint32_t>(v));
    u32(static_cast<uint32_t>(v >> 32));
  }
  void bytes(std::span<const uint8_t> b) { out.insert(out.end(), b.begin(), b.end()); }
  std::vector<uint8_t> own_;
  std::vector<uint8_t>& out;
};

class Reader {
 public:
  explicit Reader(std::span<const uint8_t> b) : b_(b) {}
  bool u8(uint8_t* v) {
    if (pos_ + 1 > b_.size()) return false;
    *v = b_[pos_++];
    return true;
  }
  bool u16(uint16_t* v) {
    uint8_t lo, hi;
    if (!u8(&lo) || !u8(&hi)) return false;
    *v = static_cast<uint16_t>(lo | (hi << 8));
    return true;
  }
  bool u32(uint32_t* v) {
    uint16_t lo, hi;
    if (!u16(&lo) || !u16(&hi)) return false;
    *v = lo | (static_cast<uint32_t>(hi) << 16);
    return true;
  }
  bool u64(uint64_t* v) {
    uint32_t lo, hi;
    if (!u32(&lo) || !u32(&hi)) return false;
    *v = lo | (static_cast<uint64_t>(hi) << 32);
    return true;
  }
  bool bytes(size_t n, std::vector<uint8_t>* out) {
    if (n > b_.size() - pos_) return false;
    out->assign(b_.begin() + static_cast<long>(pos_), b_.begin() + static_cast<long>(pos_ + n));
    pos_ += n;
    return true;
  }
  bool done() const { return pos_ == b_.size(); }

 private:
  std::span<const uint8_t> b_;
  size_t pos_ = 0;
};

// The allocating form of an encoder into a reused buffer.
template <typename T>
std::vector<uint8_t> encoded(void (*encode)(const T&, std::vector<uint8_t>*), const T& value) {
  std::vector<uint8_t> out;
  encode(value, &out);
  return out;
}

}  // namespace

Status decode_header(std::span<const uint8_t> bytes, Header* h) {
  Reader r(bytes);
  if (bytes.size() != kHeaderSize) return make_error("header is not 12 bytes");
  r.u16(&h->magic);
  r.u8(&h->version);
  r.u8(&h->type);
  r.u32(&h->seq);
  r.u32(&h->length);
  if (h->magic != kMagic) return make_error("bad magic");
  if (h->version != kVersion)
    return make_error("unsupported protocol version " + std::to_string(h->version));
  if (h->length > kMaxPayload)
    return make_error("payload of " + std::to_string(h->length) + " bytes exceeds 524288");
  switch (static_cast<Type>(h->type)) {
    case Type::kHello:
    case Type::kHelloOk:
    case Type::kTransfer:
    case Type::kReply:
    case Type::kJobEnd:
    case Type::kBusInfo:
    case Type::kBusInfoOk:
    case Type::kChannel:
    case Type::kChannelOk:
    case Type::kJobEndOk:
    case Type::kReset:
    case Type::kResetOk:
    case Type::kRevouch:
    case Type::kRevouchOk:
    case Type::kStatus:
    case Type::kStatusOk:
    case Type::kReload:
    case Type::kReloadOk:
    case Type::kGoodbye:
    case Type::kGoodbyeOk:
    case Type::kError:
      return {};
  }
  return make_error("unknown message type " + std::to_string(h->type));
}

void encode_header(Type type, uint32_t seq, uint32_t length, uint8_t out[kHeaderSize]) {
  const uint8_t h[kHeaderSize] = {static_cast<uint8_t>(kMagic),
                                  static_cast<uint8_t>(kMagic >> 8),
                                  kVersion,
                                  static_cast<uint8_t>(type),
                                  static_cast<uint8_t>(seq),
                                  static_cast<uint8_t>(seq >> 8),
                                  static_cast<uint8_t>(seq >> 16),
                                  static_cast<uint8_t>(seq >> 24),
                                  static_cast<uint8_t>(length),
                                  static_cast<uint8_t>(length >> 8),
                                  static_cast<uint8_t>(length >> 16),
                                  static_cast<uint8_t>(length >> 24)};
  std::memcpy(out, h, kHeaderSize);
}

std::vector<uint8_t> frame(Type type, uint32_t seq, std::span<const uint8_t> payload) {
  std::vector<uint8_t> out(kHeaderSize + payload.size());
  encode_header(type, seq, static_cast<uint32_t>(payload.size()), out.data());
  std::copy(payload.begin(), payload.end(), out.begin() + kHeaderSize);
  return out;
}

std::vector<uint8_t> encode_hello(const std::string& task, const Vouch& vouch) {
  Writer w;
  w.u16(static_cast<uint16_t>(task.size()));
  w.bytes({reinterpret_cast<const uint8_t*>(task.data()), task.size()});
  if (vouch.pid != 0) {
    w.u32(vouch.pid);
    w.u16(static_cast<uint16_t>(vouch.exe.size()));
    w.bytes({reinterpret_cast<const uint8_t*>(vouch.exe.data()), vouch.exe.size()});
  }
  return std::move(w.out);
}

Status decode_hello(std::span<const uint8_t> p, std::string* task, Vouch* vouch) {
  Reader r(p);
  uint16_t n = 0;
  std::vector<uint8_t> b;
  if (!r.u16(&n) || n == 0 || n > kMaxTaskName || !r.bytes(n, &b)) {
    return make_error("malformed hello (task name of 1..64 bytes expected)");
  }
  task->assign(b.begin(), b.end());
  Vouch v;
  if (!r.done()) {
    uint16_t len = 0;
    std::vector<uint8_t> exe;
    if (!r.u32(&v.pid) || v.pid == 0 || !r.u16(&len) || len == 0 || len > 4095 ||
        !r.bytes(len, &exe) || !r.done() || exe[0] != '/' ||
        std::find(exe.begin(), exe.end(), 0) != exe.end()) {
      return make_error(
          "malformed hello (a supervisor's pid and absolute program path expected after the "
          "task name)");
    }
    v.exe.assign(exe.begin(), exe.end());
  }
  if (vouch != nullptr) *vouch = v;
  return {};
}

std::vector<uint8_t> encode_hello_ok(const HelloOk& h) {
  Writer w;
  w.u16(h.task);
  w.u16(h.priority);
  return std::move(w.out);
}

Status decode_hello_ok(std::span<const uint8_t> p, HelloOk* h) {
  Reader r(p);
  if (!r.u16(&h->task) || !r.u16(&h->priority) || !r.done())
    return make_error("malformed hello answer");
  return {};
}

std::vector<uint8_t> encode_goodbye(int32_t wait_status) {
  Writer w;
  w.u32(static_cast<uint32_t>(wait_status));
  return std::move(w.out);
}

Status decode_goodbye(std::span<const uint8_t> p, int32_t* wait_status) {
  Reader r(p);
  uint32_t v = 0;
  if (!r.u32(&v) || !r.done()) return make_error("malformed goodbye (a u32 wait status expected)");
  *wait_status = static_cast<int32_t>(v);
  return {};
}

std::vector<uint8_t> encode_transfer(const Transfer& t) { return encoded(encode_transfer, t); }

void encode_transfer(const Transfer& t, std::vector<uint8_t>* out) {
  Writer w(*out);
  w.u8(t.bus);
  w.u8(static_cast<uint8_t>((t.quick ? 1 : 0) | (t.quick_read ? 2 : 0) | (t.quick_ten_bit ? 4 : 0) |
                            (t.timing.own ? kTransferOwnTiming : 0)));
  w.u16(t.quick_addr);
  w.u16(static_cast<uint16_t>(t.messages.size()));
  for (const Message& m : t.messages) {
    w.u16(m.addr);
    w.u16(m.flags);
    w.u16(m.len);
    if (!m.is_read()) w.bytes(m.data);
  }
  if (t.timing.own) {
    w.u32(t.timing.retries);
    w.u32(t.timing.timeout_10ms);
  }
}

Status decode_transfer(std::span<const uint8_t> p, Transfer* t) {
  Reader r(p);
  uint8_t flags = 0;
  uint16_t count = 0;
  if (!r.u8(&t->bus) || !r.u8(&flags) || !r.u16(&t->quick_addr) || !r.u16(&count)) {
    return make_error("truncated transfer header");
  }
  if (flags & ~(7u | kTransferOwnTiming)) return make_error("unknown transfer flags");
  t->quick = flags & 1;
  t->quick_read = flags & 2;
  t->quick_ten_bit = flags & 4;
  if (count > kMaxMessages) return make_error("more than 42 messages");
  // Reuses the messages (and their buffers) of a Transfer decoded before.
  t->messages.resize(count);
  for (Message& m : t->messages) {
    m.data.clear();
    if (!r.u16(&m.addr) || !r.u16(&m.flags) || !r.u16(&m.len))
      return make_error("truncated message header");
    if (m.len > kMaxMessageLen) return make_error("message longer than 8192 bytes");
    if (!m.is_read() && !r.bytes(m.len, &m.data)) return make_error("truncated message data");
  }
  t->timing = {(flags & kTransferOwnTiming) != 0, 0, 0};
  if (t->timing.own && (!r.u32(&t->timing.retries) || !r.u32(&t->timing.timeout_10ms)))
    return make_error("truncated I2C_RETRIES and I2C_TIMEOUT");
  if (!r.done()) return make_error("trailing bytes after the transfer");
  return validate(*t);
}

std::vector<uint8_t> encode_reply(const TransferReply& rep) { return encoded(encode_reply, rep); }

void encode_reply(const TransferReply& rep, std::vector<uint8_t>* out) {
  Writer w(*out);
  w.u32(static_cast<uint32_t>(rep.err));
  w.u16(static_cast<uint16_t>(rep.reads.size()));
  for (const auto& rd : rep.reads) {
    w.u16(static_cast<uint16_t>(rd.size()));
    w.bytes(rd);
  }
}

Status decode_reply(std::span<const uint8_t> p, TransferReply* rep) {
  Reader r(p);
  uint32_t err = 0;
  uint16_t count = 0;
  if (!r.u32(&err) || !r.u16(&count)) return make_error("truncated reply");
  if (err > 4095) return make_error("errno out of range");
  if (count > kMaxMessages) return make_error("more than 42 reads");
  rep->err = static_cast<int>(err);
  rep->reads.resize(count);  // reuses the buffers of a reply decoded before
  for (auto& rd : rep->reads) {
    uint16_t n = 0;
    if (!r.u16(&n) || n > kMaxMessageLen || !r.bytes(n, &rd))
      return make_error("truncated read data");
  }
  if (!r.done()) return make_error("trailing bytes after the reply");
  return {};
}

std::vector<uint8_t> encode_bus_info(const BusInfo& b) {
  Writer w;
  w.u8(b.present ? 1 : 0);
  w.u64(b.funcs);
  return std::move(w.out);
}

Status decode_bus_info(std::span<const uint8_t> p, BusInfo* b) {
  Reader r(p);
  uint8_t present = 0;
  if (!r.u8(&present) || present > 1 || !r.u64(&b->funcs) || !r.done())
    return make_error("malformed bus info");
  b->present = present == 1;
  return {};
}

std::vector<uint8_t> encode_error(const ErrorMsg& e) {
  Writer w;
  w.u32(static_cast<uint32_t>(e.err));
  const std::string text = e.reason.substr(0, 1024);
  w.u16(static_cast<uint16_t>(text.size()));
  w.bytes({reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  return std::move(w.out);
}

Status decode_error(std::span<const uint8_t> p, ErrorMsg* e) {
  Reader r(p);
  uint32_t err = 0;
  uint16_t n = 0;
  std::vector<uint8_t> b;
  if (!r.u32(&err) || err > 4095 || !r.u16(&n) || n > 1024 || !r.bytes(n, &b) || !r.done()) {
    return make_error("malformed error message");
  }
  e->err = static_cast<int32_t>(err);
  e->reason.assign(b.begin(), b.end());
  return {};
}

std::vector<uint8_t> encode_reload(const ReloadRequest& r) {
  Writer w;
  for (const std::string* part : {&r.bundle, &r.signature}) {
    w.u32(static_cast<uint32_t>(part->size()));
    w.bytes({reinterpret_cast<const uint8_t*>(part->data()), part->size()});
  }
  return std::move(w.out);
}

Status decode_reload(std::span<const uint8_t> p, ReloadRequest* r) {
  Reader reader(p);
  for (std::string* part : {&r->bundle, &r->signature}) {
    uint32_t n = 0;
    std::vector<uint8_t> b;
    if (!reader.u32(&n) || n > kMaxPayload || !reader.bytes(n, &b)) {
      return make_error(
          "malformed reload request (a bundle and a signature, each a u32 length and bytes)");
    }
    part->assign(b.begin(), b.end());
  }
  if (!reader.done() || r->bundle.empty()) {
    return make_error(
        "malformed reload request (a bundle and a signature, each a u32 length and bytes)");
  }
  return {};
}

}  // namespace contego::gate::wire
