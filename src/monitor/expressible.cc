#include "monitor/expressible.h"

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

namespace contego::monitor {

// Allocation-free: this runs on every transfer. The buses only read the
// bytes (Bus::expressible takes them as const), hence the const_casts.
Status emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit) {
  uint32_t offset = 0;
  for (uint32_t i = 0; i < v.emit_count && i < core::kMaxEmits; ++i) {
    const uint16_t len = v.emit_len[i];
    if (offset + len > core::kMaxEmitBytes) return {};  // perform_emits fails it closed (EIO)
    const bus::Msg m{v.addr, static_cast<uint16_t>(ten_bit ? gate::kMsgTen : 0), len,
                     const_cast<uint8_t*>(v.emit_bytes + offset)};
    offset += len;
    if (Status s = bus.expressible({&m, 1}); !s.ok()) return s;
  }
  return {};
}

bool emit_goes_with_read(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read,
                         bus::Msg* emit) {
  if (v.emit_count != 1 || v.addr != read.addr || v.emit_len[0] > core::kMaxEmitBytes) return false;
  *emit = {v.addr, static_cast<uint16_t>(read.flags & gate::kMsgTen), v.emit_len[0],
           const_cast<uint8_t*>(v.emit_bytes)};
  const bus::Msg pair[2] = {*emit, read};
  return bus.expressible(pair).ok();
}

Status pair_inexpressible(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read) {
  if (bus::Msg emit; emit_goes_with_read(bus, v, read, &emit)) return {};
  if (Status s = emits_inexpressible(bus, v, (read.flags & gate::kMsgTen) != 0); !s.ok()) return s;
  return bus.expressible({&read, 1});
}

bool acts_as_sent(const std::vector<gate::PlannedTx>& planned,
                  const std::vector<core::Verdict>& verdicts) {
  for (size_t i = 0; i < planned.size(); ++i) {
    const gate::PlannedTx& p = planned[i];
    if (p.kind == core::TxKind::kQuick) return false;
    if (p.kind != core::TxKind::kWrite) continue;
    if (!write_as_sent(verdicts[i], p)) return false;
  }
  return true;
}

bool write_as_sent(const core::Verdict& v, const gate::PlannedTx& p) {
  return contego_i2c_emits_as_sent(reinterpret_cast<const contego_verdict*>(&v), p.addr,
                                   p.bytes.data(), static_cast<uint32_t>(p.bytes.size())) != 0;
}

bus::Msg read_message(const gate::Transfer& t, const gate::PlannedTx& p) {
  const gate::Message& rm = t.messages[p.first_message + p.message_count - 1];
  return {rm.addr, rm.flags, rm.len, nullptr};
}

Status inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned) {
  for (size_t i = 0; i < planned.size(); ++i) {
    const gate::PlannedTx& p = planned[i];
    const uint16_t ten = p.ten_bit ? gate::kMsgTen : 0;
    if (i + 1 < planned.size() && planned[i + 1].answers_write) {
      const bus::Msg pair[2] = {{p.addr, ten, static_cast<uint16_t>(p.bytes.size()),
                                 const_cast<uint8_t*>(p.bytes.data())},
                                read_message(t, planned[i + 1])};
      if (bus.expressible(pair).ok()) {
        ++i;  // together, as sent
        continue;
      }
    }
    bus::Msg msgs[2];
    size_t n = 0;
    if (p.kind == core::TxKind::kQuick) {
      msgs[n++] = {p.addr, static_cast<uint16_t>(ten | (t.quick_read ? gate::kMsgRead : 0)), 0,
                   nullptr};
    } else if (p.kind == core::TxKind::kWrite || !p.bytes.empty()) {
      msgs[n++] = {p.addr, ten, static_cast<uint16_t>(p.bytes.size()),
                   const_cast<uint8_t*>(p.bytes.data())};
    }
    if (p.kind == core::TxKind::kRead) msgs[n++] = read_message(t, p);
    if (Status s = bus.expressible({msgs, n}); !s.ok()) return s;
  }
  return {};
}

}  // namespace contego::monitor
