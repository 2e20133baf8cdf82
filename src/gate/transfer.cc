#include "gate/transfer.h"

#include <string>

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

std::vector<PlannedTx> to_transactions(const Transfer& transfer) {
  std::vector<PlannedTx> out;
  if (transfer.quick) {
    PlannedTx tx;
    tx.kind = core::TxKind::kQuick;
    tx.addr = transfer.quick_addr;
    tx.ten_bit = transfer.quick_ten_bit;
    out.push_back(std::move(tx));
    return out;
  }
  const auto& msgs = transfer.messages;
  for (uint32_t i = 0; i < msgs.size(); ++i) {
    const Message& m = msgs[i];
    PlannedTx tx;
    tx.addr = m.addr;
    tx.ten_bit = (m.flags & kMsgTen) != 0;
    tx.first_message = i;
    tx.message_count = 1;
    if (m.is_read()) {
      tx.kind = core::TxKind::kRead;
    } else {
      const bool pointer = m.data.size() == 1 && i + 1 < msgs.size() && msgs[i + 1].is_read() &&
                           msgs[i + 1].addr == m.addr &&
                           (msgs[i + 1].flags & kMsgTen) == (m.flags & kMsgTen) &&
                           // General call (address 0) is write-only: a byte sent there is a
                           // command to every listener (0x06 = software reset), never a pointer.
                           m.addr != 0;
      if (pointer) {
        tx.kind = core::TxKind::kRead;
        tx.bytes = m.data;
        tx.message_count = 2;
        ++i;
      } else {
        tx.kind = core::TxKind::kWrite;
        tx.bytes = m.data;
      }
    }
    out.push_back(std::move(tx));
  }
  return out;
}

std::string validate(const Transfer& transfer) {
  if (transfer.quick) {
    if (!transfer.messages.empty()) return "quick transfer carries messages";
    if (transfer.quick_addr > (transfer.quick_ten_bit ? 0x3FF : 0x7F))
      return "address out of range";
    return {};
  }
  if (transfer.messages.empty()) return "no messages";
  if (transfer.messages.size() > kMaxMessages) return "more than 42 messages";
  for (size_t i = 0; i < transfer.messages.size(); ++i) {
    const Message& m = transfer.messages[i];
    const std::string where = "message " + std::to_string(i) + ": ";
    if (m.addr > ((m.flags & kMsgTen) ? 0x3FF : 0x7F)) return where + "address out of range";
    if (m.len > kMaxMessageLen) return where + "longer than 8192 bytes";
    if (m.is_read()) {
      if (!m.data.empty()) return where + "read message carries data";
      if ((m.flags & kMsgRecvLen) && m.len < 1 + kSmbusBlockMax) {
        return where + "RECV_LEN buffer shorter than 33 bytes";
      }
    } else {
      if (m.data.size() != m.len) return where + "length does not match its data";
      if (m.flags & kMsgRecvLen) return where + "RECV_LEN on a write";
    }
  }
  return {};
}

}  // namespace contego::gate
