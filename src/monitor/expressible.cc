#include "monitor/expressible.h"

#include <algorithm>

namespace contego::monitor {

std::string emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit) {
  uint32_t offset = 0;
  for (uint32_t i = 0; i < v.emit_count && i < core::kMaxEmits; ++i) {
    const uint16_t len = v.emit_len[i];
    if (offset + len > core::kMaxEmitBytes) return {};  // perform_emits fails it closed (EIO)
    uint8_t bytes[core::kMaxEmitBytes];
    std::copy_n(v.emit_bytes + offset, len, bytes);
    offset += len;
    const bus::Msg m{v.addr, static_cast<uint16_t>(ten_bit ? gate::kMsgTen : 0), len, bytes};
    if (Status s = bus.expressible({&m, 1}); !s.ok()) return s.error();
  }
  return {};
}

std::string inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                          const std::vector<gate::PlannedTx>& planned) {
  for (const gate::PlannedTx& p : planned) {
    const uint16_t ten = p.ten_bit ? gate::kMsgTen : 0;
    std::vector<uint8_t> bytes = p.bytes;
    std::vector<uint8_t> out;
    std::vector<bus::Msg> msgs;
    if (p.kind == core::TxKind::kQuick) {
      msgs.push_back(
          {p.addr, static_cast<uint16_t>(ten | (t.quick_read ? gate::kMsgRead : 0)), 0, nullptr});
    } else if (p.kind == core::TxKind::kWrite || !bytes.empty()) {
      msgs.push_back({p.addr, ten, static_cast<uint16_t>(bytes.size()), bytes.data()});
    }
    if (p.kind == core::TxKind::kRead) {
      const gate::Message& rm = t.messages[p.first_message + p.message_count - 1];
      out.resize(std::max<size_t>(rm.len, 1));
      msgs.push_back({rm.addr, rm.flags, rm.len, out.data()});
    }
    if (Status s = bus.expressible(msgs); !s.ok()) return s.error();
  }
  return {};
}

}  // namespace contego::monitor
