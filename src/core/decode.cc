// Device profiles inside the core: decoding a write into commands (frame and
// register-map, with staging of partial register groups) and encoding
// substitutes (templates, FAIL_SUBST, safe states) back into bus writes.
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {
void CheckerState::check_frame(const Transaction& tx, uint16_t dev) {
  const DeviceRecord& dr = devices_[dev];
  if (tx.len == 1 && dr.short_queries != 0 && tx.len != dr.frame_len) {
    return check_short_query(tx, dev);
  }
  uint32_t prefix = 0;
  if (tx.len == dr.frame_len) {
    prefix = 0;
  } else if (dr.prefix_len != 0 && tx.len == dr.frame_len + dr.prefix_len) {
    prefix = dr.prefix_len;
  } else {
    return refuse(dev, Reason::kMalformed, kEinval);
  }
  const uint8_t* frame = tx.bytes + prefix;
  const uint8_t k = state_[dev].lookup[frame[0]];
  if (k == 0xFF) return refuse(dev, Reason::kUnknownCommand, kEinval);
  Decoded& d = decode_start(dev, static_cast<uint16_t>(dr.command_first + k), 0, dr.frame_len);
  d.prefix = static_cast<uint8_t>(prefix);
  d.prefix_byte = prefix ? tx.bytes[0] : 0;
  __builtin_memcpy(d.bytes, frame, dr.frame_len);
  decode_fields(d);
  if (Outcome* o = check_as_is(tx, dev)) {
    o->bus_command = d.command;
    copy_fields(o->bus_fields, d.fields);
  }
}

// A one-byte write naming a query: decoded as that query with no fields (it
// needs read access); any other single byte is malformed.
void CheckerState::check_short_query(const Transaction& tx, uint16_t dev) {
  const DeviceRecord& dr = devices_[dev];
  const uint8_t k = state_[dev].lookup[tx.bytes[0]];
  if (k == 0xFF || commands_[dr.command_first + k].command_class != CommandClass::kQuery) {
    return refuse(dev, Reason::kMalformed, kEinval);
  }
  Decoded& d = decode_start(dev, static_cast<uint16_t>(dr.command_first + k), 0, 1);
  d.bytes[0] = tx.bytes[0];
  __builtin_memset(d.fields, 0, sizeof(d.fields));
  check_as_is(tx, dev);
}

// Checks the decoded command; allowed, the transaction's bytes go on exactly
// as checked (prefix included). Returns its outcome if allowed.
Outcome* CheckerState::check_as_is(const Transaction& tx, uint16_t dev) {
  Outcome* o = new_outcome(dev);
  if (o == nullptr) return nullptr;
  evaluate(tx, *o);
  if (o->decision != Decision::kAllow) return nullptr;
  emit(tx.bytes, tx.len);
  o->emit_len = static_cast<uint16_t>(tx.len);
  return o;
}

// Starts decoding command `cid` (channel `index`, `len` bytes) of `dev`.
Decoded& CheckerState::decode_start(uint16_t dev, uint16_t cid, uint8_t index, uint32_t len) {
  Decoded& d = decoded_;
  d.device = dev;
  d.command = cid;
  d.index = index;
  d.prefix = 0;
  d.prefix_byte = 0;
  d.base_reg = 0;
  d.len = len;
  d.field_count = 0;
  return d;
}

void CheckerState::decode_fields(Decoded& d) {
  const CommandRecord& c = commands_[d.command];
  d.field_count = c.field_count;
  for (uint32_t f = 0; f < c.field_count; ++f) {
    d.fields[f] = field_get(fields_[c.field_first + f], d.bytes);
  }
}

// One byte to the general-call address is a command (0x06 = software reset
// on a PCA9685), not a register pointer: one of the device's general-call
// commands, or refused.
void CheckerState::check_general_call_command(const Transaction& tx, uint16_t dev) {
  const DeviceRecord& dr = devices_[dev];
  for (uint32_t k = 0; k < dr.command_count; ++k) {
    const uint16_t cid = static_cast<uint16_t>(dr.command_first + k);
    const CommandRecord& c = commands_[cid];
    if (c.group_len != 0 || c.match != tx.bytes[0]) continue;
    decode_start(dev, cid, 0, 0);
    Outcome* o = new_outcome(dev);
    if (o == nullptr) return;
    evaluate(tx, *o);
    if (o->decision == Decision::kAllow) {
      o->bus_command = cid;  // check() emits the broadcast
      __builtin_memset(o->bus_fields, 0, sizeof(o->bus_fields));
    }
    return;
  }
  refuse(dev, Reason::kUnknownCommand, kEinval);
}

// Nothing staged on the device (most writes): no call, nothing to drop.
static bool anything_staged(const DeviceState& st) {
  uint32_t staged = 0;
  for (uint32_t w = 0; w < kMaxRegisters / 32; ++w) staged |= st.staged_bits[w];
  return staged != 0;
}

// Before the task writes the group at `base`: other tasks' staged bytes of it
// are displaced (settle_model() audits them if the write acts), and the
// task's own of any other group, left incomplete, are dropped and audited.
void CheckerState::drop_stale_staging(const Transaction& tx, uint16_t dev, uint16_t cid,
                                      uint32_t base) {
  DeviceState& st = state_[dev];
  uint32_t last_group = 0xFFFFFFFFu;
  for (uint32_t w = 0; w < kMaxRegisters / 32; ++w) {
    for (uint32_t bits = st.staged_bits[w]; bits != 0; bits &= bits - 1) {
      const uint32_t r = w * 32 + static_cast<uint32_t>(__builtin_ctz(bits));
      const bool inside = r - base < commands_[cid].group_len;
      if (inside == (st.staged_task[r] == tx.task)) continue;
      if (inside) {
        undo_save(dev, static_cast<uint8_t>(r));
        bit_clear(st.staged_bits, r);
      } else {
        drop_staged(dev, r);
        audit_staging_drop(tx, dev, r, st.staged_task[r], Reason::kStagedIncomplete, last_group);
      }
    }
  }
}

// One record per group (`last_group`: the last one recorded) for a staged
// byte of `victim` at `reg` that will never reach the device.
void CheckerState::audit_staging_drop(const Transaction& tx, uint16_t dev, uint32_t reg,
                                      uint16_t victim, Reason reason, uint32_t& last_group) {
  const uint16_t c = static_cast<uint16_t>(devices_[dev].command_first + state_[dev].lookup[reg]);
  const uint32_t i =
      commands_[c].stride != 0 ? (reg - commands_[c].match) / commands_[c].stride : 0;
  if (((uint32_t{c} << 8) | i) == last_group || host_.audit == nullptr) return;
  last_group = (uint32_t{c} << 8) | i;
  AuditRecord a = audit_record(tx, dev, c, Decision::kIgnore, reason);
  a.task = victim;
  a.index = static_cast<uint8_t>(i);
  host_.audit(host_.context, &a);
}

// A register of a group the task can never send now (no actuate access, the
// device latched, a limit of 0 per job): decided at once, as its commit
// would be, instead of held for a last register that may never come.
bool CheckerState::never_acts(const Transaction& tx, uint16_t dev, uint16_t cid,
                              uint32_t index) const {
  if (((access_[tx.task].actuate_devices >> dev) & 1u) == 0 || state_[dev].latched) return true;
  for (uint64_t bits = rates_of_[tx.task][dev]; bits != 0; bits &= bits - 1) {
    const RateRecord& rr = rates_[__builtin_ctzll(bits)];
    if (rr.max_per_job == 0 && mask_has(rr.commands, cid) &&
        (rr.only_channel == 0 || index == rr.only_channel - 1u)) {
      return true;
    }
  }
  return false;
}

// The group's last register was written: commit = shadow overlaid with the
// staged bytes and `val` at offset `j`, checked as one command.
void CheckerState::commit_group(const Transaction& tx, uint16_t dev, uint16_t cid, uint32_t base,
                                uint32_t index, uint32_t j, uint8_t val) {
  DeviceState& st = state_[dev];
  const CommandRecord& c = commands_[cid];
  Decoded& d = decode_start(dev, cid, static_cast<uint8_t>(index), c.group_len);
  d.base_reg = static_cast<uint8_t>(base);
  d.written[0] = 0;
  // A one-register group (MODE2, PRE_SCALE) is never staged: nothing to overlay.
  if (c.group_len > 1) {
    __builtin_memset(d.written, 0, sizeof(d.written));
    for (uint32_t q = 0; q < c.group_len; ++q) {
      const uint32_t r = base + q;
      if (bit_test(st.staged_bits, r)) {
        d.bytes[q] = st.staged[r];
        bit_set(d.written, q);
        undo_save(dev, static_cast<uint8_t>(r));
        bit_clear(st.staged_bits, r);
      } else {
        d.bytes[q] = st.shadow[r];
      }
    }
  }
  d.bytes[j] = val;
  bit_set(d.written, j);
  decode_fields(d);
  Outcome* o = new_outcome(dev);
  if (o == nullptr) return;
  o->base_reg = d.base_reg;
  o->group_len = c.group_len;
  const DeviceRecord& dr = devices_[dev];
  if (dr.gated != 0 && cid == dr.command_first + dr.gated - 1u &&
      ((st.shadow[dr.ai_reg] >> dr.gate_bit) & 1u) == 0 &&
      ((access_[tx.task].actuate_devices >> dev) & 1u) != 0 && !rate_decides(tx, d)) {
    // The device would drop it now (PCA9685 PRE_SCALE while the oscillator
    // runs): not sent, the shadow keeps what the device holds, no rule spent
    // (a rate rule that drops it anyway answers as it would: its errno).
    o->command = cid;
    return decide(*o, Decision::kIgnore, Reason::kNotTaken, RuleKind::kNoRule, kNone, 0);
  }
  evaluate(tx, *o);
  if (o->decision != Decision::kAllow) return;
  auto send = [&](uint32_t q) {
    const uint8_t r = static_cast<uint8_t>(base + q);
    const uint8_t pair[2] = {r, d.bytes[q]};
    emit(pair, 2);
    store_shadow(dev, cid, r, d.bytes[q]);
  };
  if (c.group_len == 1) send(0);
  for (uint32_t q = 0; c.group_len > 1 && q < c.group_len; ++q) {
    if (bit_test(d.written, q)) send(q);
  }
  o->emit_len = static_cast<uint16_t>(tx_.out->emit_bytes_used - o->emit_offset);
  o->bus_command = cid;
  o->bus_index = d.index;
  copy_fields(o->bus_fields, d.fields);
}

void CheckerState::check_register_map(const Transaction& tx, uint16_t dev) {
  const DeviceRecord& dr = devices_[dev];
  DeviceState& st = state_[dev];
  if (tx.len == 0) return refuse(dev, Reason::kMalformed, kEinval);
  if (tx.len == 1 && general_call_) return check_general_call_command(tx, dev);
  if (tx.len == 1) {
    // Register pointer only (the first half of a register read): no register
    // changes, so it needs read access like the read that follows.
    Outcome* o = new_outcome(dev);
    if (o == nullptr) return;
    decide_read(*o, tx, dev);
    if (o->decision == Decision::kAllow) {
      emit(tx.bytes, 1);
      o->emit_len = 1;
    }
    return;
  }
  const bool ai =
      dr.auto_increment == AutoIncrement::kAlways ||
      (dr.auto_increment == AutoIncrement::kBit && ((st.shadow[dr.ai_reg] >> dr.ai_bit) & 1u));
  const uint32_t first = tx.bytes[0];
  const uint32_t n = tx.len - 1;
  if (ai && first + n > kMaxRegisters) return refuse(dev, Reason::kMalformed, kEinval);
  uint32_t dropped_cid = kNone;  // the group whose foreign staging this write already dropped
  uint32_t dropped_index = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const uint8_t reg = static_cast<uint8_t>(ai ? first + i : first);
    const uint8_t val = tx.bytes[1 + i];
    const uint8_t k = st.lookup[reg];
    if (k == 0xFF) return refuse(dev, Reason::kUnknownCommand, kEinval);
    const uint16_t cid = static_cast<uint16_t>(dr.command_first + k);
    const CommandRecord& c = commands_[cid];
    if (c.command_class == CommandClass::kForbidden) {
      // Decoded far enough to know it is forbidden: evaluate() records the violation.
      decode_start(dev, cid, 0, 0);
      Outcome* o = new_outcome(dev);
      if (o != nullptr) evaluate(tx, *o);
      return;
    }
    const uint32_t index = c.stride != 0 ? (reg - c.match) / c.stride : 0;
    const uint32_t base = c.match + index * c.stride;
    const uint32_t j = reg - base;
    // Once per group and write: after the first of its registers, no other
    // task's staging is left in it.
    if ((cid != dropped_cid || index != dropped_index) && anything_staged(st)) {
      drop_stale_staging(tx, dev, cid, base);
      dropped_cid = cid;
      dropped_index = index;
    }
    if (j + 1 == c.group_len || never_acts(tx, dev, cid, index)) {
      commit_group(tx, dev, cid, base, index, j, val);
      continue;
    }
    undo_save(dev, reg);
    st.staged[reg] = val;
    st.staged_task[reg] = static_cast<uint8_t>(tx.task);
    bit_set(st.staged_bits, reg);
    if (tx_.staged_command == kNone) {
      tx_.staged_command = cid;
      tx_.staged_index = static_cast<uint8_t>(index);
    }
  }
}

// Encodes a substitute command: the base bytes (the checked frame for the
// checked command, else the opcode and zeros; for register maps the shadow
// group), with the selected fields replaced. False if a value does not fit.
bool CheckerState::build_substitute(const Subst& subst, const Decoded* request, uint16_t dev,
                                    Encoded& e) {
  const uint16_t cid = subst.command != kNone ? subst.command
                       : request != nullptr   ? request->command
                                              : kNone;
  if (cid == kNone || cid >= command_count_ || commands_[cid].device != dev) return false;
  const CommandRecord& c = commands_[cid];
  const DeviceRecord& dr = devices_[dev];
  e.command = cid;
  e.index = 0;
  if (dr.profile == Profile::kFrame) {
    e.len = dr.frame_len;
    if (request != nullptr && request->command == cid) {
      __builtin_memcpy(e.bytes, request->bytes, dr.frame_len);
    } else {
      __builtin_memset(e.bytes, 0, dr.frame_len);
      e.bytes[0] = c.match;
    }
  } else {
    // The template's channel; else the checked command's when the substitute
    // has it; else channel 0. The verifier keeps a template's index < repeat.
    if (subst.index != kSameIndex) {
      e.index = subst.index;
    } else if (request != nullptr && request->index < c.repeat) {
      e.index = request->index;
    }
    e.len = c.group_len;
    __builtin_memcpy(e.bytes, state_[dev].shadow + c.match + e.index * c.stride, c.group_len);
  }
  for (uint32_t f = 0; f < c.field_count; ++f) {
    if (((subst.set_mask >> f) & 1u) == 0) continue;
    if (!field_put(fields_[c.field_first + f], subst.values[f], e.bytes)) return false;
  }
  if ((subst.set_mask >> c.field_count) != 0) return false;  // a field the command lacks
  for (uint32_t f = 0; f < kMaxFieldsPerCommand; ++f) {
    e.fields[f] = f < c.field_count ? field_get(fields_[c.field_first + f], e.bytes) : 0;
  }
  return true;
}

bool CheckerState::emit_encoded(uint16_t dev, const Decoded* request, const Encoded& e) {
  if (devices_[dev].profile == Profile::kFrame) {
    uint8_t framed[kMaxWriteBytes + 1];
    uint32_t n = 0;
    if (request != nullptr && request->prefix != 0) framed[n++] = request->prefix_byte;
    __builtin_memcpy(framed + n, e.bytes, e.len);
    return emit(framed, n + e.len);
  }
  const CommandRecord& c = commands_[e.command];
  const uint32_t base = c.match + e.index * c.stride;
  for (uint32_t q = 0; q < e.len; ++q) {
    const uint8_t r = static_cast<uint8_t>(base + q);
    const uint8_t pair[2] = {r, e.bytes[q]};
    if (!emit(pair, 2)) return false;
    store_shadow(dev, e.command, r, e.bytes[q]);
  }
  return true;
}

bool CheckerState::emit_substitute(const Subst& subst, Outcome& o) {
  Encoded e;
  if (!subst.active || !build_substitute(subst, &decoded_, decoded_.device, e)) return false;
  if (!emit_encoded(decoded_.device, &decoded_, e)) {
    tx_.emit_failed = false;  // this command fails closed on its own; others are unaffected
    tx_.out->emit_count = o.emit_index;
    tx_.out->emit_bytes_used = o.emit_offset;
    return false;
  }
  o.emit_len = static_cast<uint16_t>(tx_.out->emit_bytes_used - o.emit_offset);
  o.bus_command = e.command;
  o.bus_index = e.index;
  copy_fields(o.bus_fields, e.fields);
  return true;
}

// A loaded register-map device: one with registers to seed, list or read.
bool CheckerState::register_map(uint16_t device) const {
  return loaded_ && device < device_count_ && devices_[device].profile == Profile::kRegisterMap;
}

// The shadow of a register-map device, seeded by the host (read back from
// the device after a load, before anything is checked).
bool CheckerState::seed_register(uint16_t device, uint8_t reg, uint8_t value) {
  if (!register_map(device)) return false;
  state_[device].shadow[reg] = value;
  return true;
}

// Every register a command group of `device` covers (match + i*stride + j),
// ascending and once each: the registers whose shadow a check can read.
uint32_t CheckerState::command_registers(uint16_t device, uint8_t* regs) const {
  if (!register_map(device)) return 0;
  uint64_t covered[kMaxRegisters / 64] = {};
  for (uint32_t c = 0; c < command_count_; ++c) {
    const CommandRecord& r = commands_[c];
    if (r.device != device) continue;
    for (uint32_t i = 0; i < r.repeat; ++i) {
      for (uint32_t j = 0; j < r.group_len; ++j) {
        const uint32_t reg = r.match + i * r.stride + j;
        if (reg < kMaxRegisters) covered[reg / 64] |= uint64_t{1} << (reg % 64);
      }
    }
  }
  uint32_t n = 0;
  for (uint32_t reg = 0; reg < kMaxRegisters; ++reg) {
    if (covered[reg / 64] >> (reg % 64) & 1) regs[n++] = static_cast<uint8_t>(reg);
  }
  return n;
}

}  // namespace contego::core::internal

namespace contego::core {

bool Checker::seed_register(uint16_t device, uint8_t reg, uint8_t value) {
  return state().seed_register(device, reg, value);
}
uint32_t Checker::command_registers(uint16_t device, uint8_t* regs) const {
  return state().command_registers(device, regs);
}

}  // namespace contego::core
