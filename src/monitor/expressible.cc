#include "monitor/expressible.h"

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

Status inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned) {
  for (const gate::PlannedTx& p : planned) {
    const uint16_t ten = p.ten_bit ? gate::kMsgTen : 0;
    bus::Msg msgs[2];
    size_t n = 0;
    if (p.kind == core::TxKind::kQuick) {
      msgs[n++] = {p.addr, static_cast<uint16_t>(ten | (t.quick_read ? gate::kMsgRead : 0)), 0,
                   nullptr};
    } else if (p.kind == core::TxKind::kWrite || !p.bytes.empty()) {
      msgs[n++] = {p.addr, ten, static_cast<uint16_t>(p.bytes.size()),
                   const_cast<uint8_t*>(p.bytes.data())};
    }
    if (p.kind == core::TxKind::kRead) {  // a read's buffer is not needed to plan it
      const gate::Message& rm = t.messages[p.first_message + p.message_count - 1];
      msgs[n++] = {rm.addr, rm.flags, rm.len, nullptr};
    }
    if (Status s = bus.expressible({msgs, n}); !s.ok()) return s;
  }
  return {};
}

}  // namespace contego::monitor
