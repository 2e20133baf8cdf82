// contego/i2c_plan.h: a combined transfer as the core's transactions, the
// one normalisation both clients apply. Freestanding.
#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

extern "C" uint32_t contego_i2c_transactions(const contego_i2c_msg* msgs, uint32_t n,
                                             contego_i2c_tx* out) {
  constexpr uint16_t kTen = CONTEGO_I2C_M_TEN;
  uint32_t t = 0;
  for (uint32_t i = 0; i < n; ++i, ++t) {
    const contego_i2c_msg& m = msgs[i];
    contego_i2c_tx& tx = out[t];
    tx = contego_i2c_tx{};
    tx.addr = m.addr;
    tx.ten = (m.flags & kTen) ? 1 : 0;
    tx.first_msg = i;
    tx.msg_count = 1;
    if (m.flags & CONTEGO_I2C_M_RD) {
      tx.kind = CONTEGO_TX_READ;
      continue;
    }
    tx.bytes = m.buf;
    tx.len = m.len;
    // A one-byte write then a read of the same address is that read's
    // register pointer. Not at the general call address 0, which is
    // write-only: a byte sent there is a command to every listener (0x06 =
    // software reset), never a pointer.
    const contego_i2c_msg* next = i + 1 < n ? &msgs[i + 1] : nullptr;
    if (m.len == 1 && next != nullptr && (next->flags & CONTEGO_I2C_M_RD) && next->addr == m.addr &&
        (next->flags & kTen) == (m.flags & kTen) && m.addr != 0) {
      tx.kind = CONTEGO_TX_READ;
      tx.msg_count = 2;
      ++i;
    } else {
      tx.kind = CONTEGO_TX_WRITE;
    }
  }
  return t;
}

extern "C" int contego_i2c_write_then_read(const contego_i2c_tx* a, const contego_i2c_tx* b) {
  return a->kind == CONTEGO_TX_WRITE && b->kind == CONTEGO_TX_READ && b->msg_count == 1 &&
         a->len > 0 && a->addr == b->addr && a->ten == b->ten && a->addr != 0 &&
         b->first_msg == a->first_msg + a->msg_count;
}

extern "C" int contego_i2c_emits_as_sent(const contego_verdict* v, uint16_t addr,
                                         const uint8_t* bytes, uint32_t len) {
  if (v->addr != addr || v->emit_count == 0 || v->emit_count > CONTEGO_MAX_EMITS || len == 0) {
    return 0;
  }
  uint32_t at = 0;    // in emit_bytes
  uint32_t data = 1;  // in bytes: the next data byte (bytes[0] is the first register)
  uint32_t reg = bytes[0];
  for (uint32_t i = 0; i < v->emit_count; ++i) {
    const uint32_t n = v->emit_len[i];
    if (n == 0 || at + n > CONTEGO_MAX_EMIT_BYTES || v->emit_bytes[at] != reg ||
        data + (n - 1) > len || (n == 1 && v->emit_count > 1)) {
      return 0;
    }
    for (uint32_t k = 1; k < n; ++k) {
      if (v->emit_bytes[at + k] != bytes[data + k - 1]) return 0;
    }
    reg += n - 1;
    data += n - 1;
    at += n;
  }
  return data == len;
}
