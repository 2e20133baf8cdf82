#include "gate/transfer.h"

#include <algorithm>
#include <string>

#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

namespace contego::gate {

bool is_probe(const Transfer& t) {
  if (t.quick) return true;
  const auto& m = t.messages;
  for (size_t i = 0; i < m.size(); ++i) {
    if (m[i].is_read()) continue;
    const bool pointer = m[i].data.size() == 1 && i + 1 < m.size() && m[i + 1].is_read() &&
                         m[i + 1].addr == m[i].addr;
    if (!pointer) return false;
  }
  return !m.empty();
}

void to_transactions(const Transfer& transfer, std::vector<PlannedTx>& out) {
  size_t n = 0;
  // Elements are reused, byte buffers and all: a caller that keeps `out`
  // allocates nothing per transfer once it has seen its largest one.
  auto next = [&]() -> PlannedTx& {
    if (n == out.size()) out.emplace_back();
    PlannedTx& tx = out[n++];
    tx.kind = core::TxKind::kWrite;
    tx.addr = 0;
    tx.ten_bit = false;
    tx.bytes.clear();
    tx.first_message = 0;
    tx.message_count = 0;
    tx.answers_write = false;
    return tx;
  };
  if (transfer.quick) {
    PlannedTx& tx = next();
    tx.kind = core::TxKind::kQuick;
    tx.addr = transfer.quick_addr;
    tx.ten_bit = transfer.quick_ten_bit;
    out.resize(n);
    return;
  }
  // The shared normalisation (contego/i2c_plan.h), over the messages as
  // struct i2c_msg; validate() has bounded them to 42.
  const auto& msgs = transfer.messages;
  contego_i2c_msg raw[kMaxMessages];
  contego_i2c_tx txs[kMaxMessages];
  const uint32_t count = static_cast<uint32_t>(std::min<size_t>(msgs.size(), kMaxMessages));
  for (uint32_t i = 0; i < count; ++i) {
    // Only a write's bytes are read, never written through.
    raw[i] = {msgs[i].addr, msgs[i].flags, msgs[i].len, const_cast<uint8_t*>(msgs[i].data.data())};
  }
  const uint32_t planned = contego_i2c_transactions(raw, count, txs);
  for (uint32_t k = 0; k < planned; ++k) {
    const contego_i2c_tx& c = txs[k];
    PlannedTx& tx = next();
    tx.kind = static_cast<core::TxKind>(c.kind);
    tx.addr = c.addr;
    tx.ten_bit = c.ten != 0;
    tx.first_message = c.first_msg;
    tx.message_count = c.msg_count;
    tx.answers_write = k > 0 && contego_i2c_write_then_read(&txs[k - 1], &c);
    if (c.kind != CONTEGO_TX_READ || c.msg_count == 2) tx.bytes.assign(c.bytes, c.bytes + c.len);
  }
  out.resize(n);
}

std::vector<PlannedTx> to_transactions(const Transfer& transfer) {
  std::vector<PlannedTx> out;
  to_transactions(transfer, out);
  return out;
}

Status validate(const Transfer& transfer) {
  if (!contego_i2c_timing_arg_ok(0, transfer.timing.retries) ||
      !contego_i2c_timing_arg_ok(1, transfer.timing.timeout_10ms)) {
    return make_error("I2C_RETRIES or I2C_TIMEOUT beyond i2c-dev's limits");
  }
  if (transfer.quick) {
    if (!transfer.messages.empty()) return make_error("quick transfer carries messages");
    if (transfer.quick_addr > (transfer.quick_ten_bit ? 0x3FF : 0x7F))
      return make_error("address out of range");
    return {};
  }
  if (transfer.messages.empty()) return make_error("no messages");
  if (transfer.messages.size() > kMaxMessages) return make_error("more than 42 messages");
  // The message's number is put into the answer only when there is one to
  // give: a valid transfer, the common case, costs no string at all.
  auto bad = [](size_t i, const char* what) {
    return make_error("message " + std::to_string(i) + ": " + what);
  };
  for (size_t i = 0; i < transfer.messages.size(); ++i) {
    const Message& m = transfer.messages[i];
    if (const unsigned refused = contego_i2c_refused_flags(m.flags); refused != 0) {
      return make_error("message " + std::to_string(i) + ": flag " +
                        contego_i2c_flag_name(refused) +
                        " is not allowed (contego/i2c_msg_flags.h)");
    }
    if (m.addr > ((m.flags & kMsgTen) ? 0x3FF : 0x7F)) return bad(i, "address out of range");
    if (m.len > kMaxMessageLen) return bad(i, "longer than 8192 bytes");
    if (m.is_read()) {
      if (!m.data.empty()) return bad(i, "read message carries data");
      if ((m.flags & kMsgRecvLen) && m.len < 1 + kSmbusBlockMax) {
        return bad(i, "RECV_LEN buffer shorter than 33 bytes");
      }
    } else {
      if (m.data.size() != m.len) return bad(i, "length does not match its data");
      if (m.flags & kMsgRecvLen) return bad(i, "RECV_LEN on a write");
    }
  }
  return {};
}

}  // namespace contego::gate
