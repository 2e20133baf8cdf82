// contego/i2c_plan.h: whether every part of a call has a form on the
// adapter, in the shape both clients send it: the program's bytes before the
// core decides, what the verdicts send before the call is committed.
// Freestanding.
#include "contego/core_c.h"
#include "contego/i2c_msg_flags.h"
#include "contego/i2c_plan.h"

namespace {

// Whether the planner has a form for these messages; if not, *why gets them.
bool has_form(const contego_i2c_msg* m, uint32_t n, uint64_t funcs, uint32_t tx,
              contego_i2c_formless* why) {
  contego_i2c_plan plan;
  contego_i2c_plan_transfer(m, n, funcs, &plan);
  if (plan.form != CONTEGO_I2C_FORM_REFUSED) return true;
  why->tx = tx;
  why->n = n;
  for (uint32_t i = 0; i < n && i < 2; ++i) why->msgs[i] = m[i];
  why->plan = plan;
  return false;
}

}  // namespace

extern "C" int contego_i2c_acts_as_sent(const contego_i2c_tx* txs, const contego_verdict* v,
                                        uint32_t n) {
  for (uint32_t i = 0; i < n; ++i) {
    const contego_i2c_tx& tx = txs[i];
    if (tx.kind == CONTEGO_TX_QUICK) return 0;
    if (tx.kind == CONTEGO_TX_WRITE && !contego_i2c_emits_as_sent(&v[i], tx.addr, tx.bytes, tx.len))
      return 0;
  }
  return 1;
}

extern "C" int contego_i2c_emit_with_read(const contego_verdict* v, const contego_i2c_msg* read,
                                          uint64_t funcs, contego_i2c_msg* emit) {
  if (v->emit_count != 1 || v->addr != read->addr || v->emit_len[0] > CONTEGO_MAX_EMIT_BYTES) {
    return 0;
  }
  // The senders copy the bytes before the bus sees them; the planner only reads.
  const contego_i2c_msg pair[2] = {{v->addr, static_cast<uint16_t>(read->flags & CONTEGO_I2C_M_TEN),
                                    v->emit_len[0], const_cast<uint8_t*>(v->emit_bytes)},
                                   *read};
  contego_i2c_plan plan;
  contego_i2c_plan_transfer(pair, 2, funcs, &plan);
  if (plan.form == CONTEGO_I2C_FORM_REFUSED) return 0;
  *emit = pair[0];
  return 1;
}

extern "C" int contego_i2c_emits_have_forms(const contego_verdict* v, uint16_t ten, uint64_t funcs,
                                            contego_i2c_formless* why) {
  uint32_t offset = 0;
  for (uint32_t i = 0; i < v->emit_count && i < CONTEGO_MAX_EMITS; ++i) {
    const uint16_t len = v->emit_len[i];
    // Malformed (the core never makes one): both senders check this before
    // any byte of the verdict goes out, and fail with EIO.
    if (offset + len > CONTEGO_MAX_EMIT_BYTES) return 1;
    const contego_i2c_msg m{v->addr, static_cast<uint16_t>(ten & CONTEGO_I2C_M_TEN), len,
                            const_cast<uint8_t*>(v->emit_bytes + offset)};
    offset += len;
    if (!has_form(&m, 1, funcs, 0, why)) return 0;
  }
  return 1;
}

extern "C" int contego_i2c_call_has_forms(const contego_i2c_msg* msgs, uint32_t nmsgs,
                                          const contego_i2c_tx* txs, const contego_verdict* v,
                                          uint32_t n, uint64_t funcs, contego_i2c_formless* why) {
  // Decided and acting as sent: the call whole, as a client tries it first.
  if (v != nullptr && contego_i2c_acts_as_sent(txs, v, n) && has_form(msgs, nmsgs, funcs, 0, why)) {
    return 1;
  }
  for (uint32_t i = 0; i < n; ++i) {
    const contego_i2c_tx& tx = txs[i];
    const contego_i2c_msg* m = &msgs[tx.first_msg];
    if (tx.kind != CONTEGO_TX_WRITE) {
      if (!has_form(m, tx.msg_count, funcs, i, why)) return 0;
      continue;
    }
    if (i + 1 < n && contego_i2c_write_then_read(&tx, &txs[i + 1])) {
      const contego_i2c_msg pair[2] = {*m, msgs[txs[i + 1].first_msg]};
      contego_i2c_msg emit;
      if (v == nullptr ? has_form(pair, 2, funcs, i, why)
                       : contego_i2c_emit_with_read(&v[i], &pair[1], funcs, &emit)) {
        ++i;  // together; else the read goes alone, as the next transaction
        continue;
      }
    }
    if (v == nullptr
            ? !has_form(m, 1, funcs, i, why)
            : !contego_i2c_emits_have_forms(&v[i], tx.ten ? CONTEGO_I2C_M_TEN : 0, funcs, why)) {
      why->tx = i;
      return 0;
    }
  }
  return 1;
}
