#include "monitor/expressible.h"

#include <algorithm>

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

#include "bus/smbus_plan.h"

namespace contego::monitor {

namespace {

const contego_verdict* c_verdict(const core::Verdict& v) {
  return reinterpret_cast<const contego_verdict*>(&v);
}

// Why the part the shared model names has no form, in the planner's words.
Status formless(const bus::Bus& bus, const contego_i2c_formless& why) {
  bus::Msg part[2];
  const uint32_t n = why.n < 2 ? why.n : 2;
  for (uint32_t k = 0; k < n; ++k) {
    part[k] = {why.msgs[k].addr, why.msgs[k].flags, why.msgs[k].len, why.msgs[k].buf};
  }
  return make_error(bus::refusal_reason({part, n}, bus.funcs(), why.plan));
}

}  // namespace

// Allocation-free but for a refusal's reason: this runs on every transfer.
Status emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit) {
  contego_i2c_formless why;
  if (contego_i2c_emits_have_forms(c_verdict(v), ten_bit ? gate::kMsgTen : 0, bus.funcs(), &why)) {
    return {};
  }
  return formless(bus, why);
}

bool emit_goes_with_read(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read,
                         bus::Msg* emit) {
  const contego_i2c_msg r{read.addr, read.flags, read.len, read.buf};
  contego_i2c_msg e;
  if (!contego_i2c_emit_with_read(c_verdict(v), &r, bus.funcs(), &e)) return false;
  *emit = {e.addr, e.flags, e.len, e.buf};
  return true;
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
                     const std::vector<gate::PlannedTx>& planned,
                     const std::vector<core::Verdict>* verdicts) {
  // The call as the shared model takes it (struct i2c_msg's layout, the
  // transactions contego_i2c_transactions made); validate() has bounded it
  // to 42 messages. A quick command is its zero-length message.
  contego_i2c_msg msgs[gate::kMaxMessages];
  contego_i2c_tx txs[gate::kMaxMessages];
  uint32_t nmsgs = 0;
  if (t.quick) {
    msgs[nmsgs++] = {t.quick_addr,
                     static_cast<uint16_t>((t.quick_ten_bit ? gate::kMsgTen : 0) |
                                           (t.quick_read ? gate::kMsgRead : 0)),
                     0, nullptr};
  }
  for (const gate::Message& m : t.messages) {
    if (nmsgs == gate::kMaxMessages) break;
    msgs[nmsgs++] = {m.addr, m.flags, m.len,
                     m.is_read() ? nullptr : const_cast<uint8_t*>(m.data.data())};
  }
  size_t n = std::min<size_t>(planned.size(), gate::kMaxMessages);
  if (verdicts != nullptr) n = std::min(n, verdicts->size());
  for (size_t i = 0; i < n; ++i) {
    const gate::PlannedTx& p = planned[i];
    txs[i] = {static_cast<uint8_t>(p.kind),
              static_cast<uint8_t>(p.ten_bit ? 1 : 0),
              p.addr,
              static_cast<uint32_t>(p.bytes.size()),
              p.bytes.data(),
              p.first_message,
              p.kind == core::TxKind::kQuick ? 1 : p.message_count};
  }
  contego_i2c_formless why;
  const contego_verdict* v = verdicts != nullptr && n > 0 ? c_verdict((*verdicts)[0]) : nullptr;
  if (contego_i2c_call_has_forms(msgs, nmsgs, txs, v, static_cast<uint32_t>(n), bus.funcs(),
                                 &why)) {
    return {};
  }
  return formless(bus, why);
}

}  // namespace contego::monitor
