// The check path: transaction → device → command(s) → class, access, latch,
// rate, invariants → combined verdict + audit. docs/core.md describes the
// order and the semantics; this file is their implementation.
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {

Outcome* CheckerState::new_outcome(uint16_t dev) {
  if (tx_.outcome_count >= kMaxCommandsPerTransaction) {
    tx_.overflow = true;
    return nullptr;
  }
  Outcome& o = tx_.outcomes[tx_.outcome_count++];
  o.device = dev;
  o.command = kNone;
  o.index = 0;
  o.field_count = 0;
  o.base_reg = 0;
  o.group_len = 0;
  o.decision = Decision::kAllow;
  o.reason = Reason::kAllowed;
  o.rule_kind = RuleKind::kNoRule;
  o.reply_errno = 0;
  o.rule = kNone;
  o.emit_offset = tx_.out->emit_bytes_used;
  o.emit_len = 0;
  o.emit_index = tx_.out->emit_count;
  o.bus_command = kNone;
  o.bus_index = 0;
  return &o;
}

void decide(Outcome& o, Decision d, Reason r, RuleKind kind, uint16_t rule, uint8_t err) {
  o.decision = d;
  o.reason = r;
  o.rule_kind = kind;
  o.rule = rule;
  o.reply_errno = d == Decision::kReject ? err : 0;
}

// A new outcome of `dev` refused with `reason`, no rule (none when the
// transaction has too many: finish() refuses it all).
void CheckerState::refuse(uint16_t dev, Reason reason, uint8_t err) {
  Outcome* o = new_outcome(dev);
  if (o != nullptr) decide(*o, Decision::kReject, reason, RuleKind::kNoRule, kNone, err);
}

// A read, a query or a register pointer: the task's read bit decides.
void CheckerState::decide_read(Outcome& o, const Transaction& tx, uint16_t dev) const {
  if ((access_[tx.task].read_devices >> dev) & 1u) {
    decide(o, Decision::kAllow, Reason::kReadAllowed, RuleKind::kNoRule, kNone, 0);
  } else {
    decide(o, Decision::kReject, Reason::kReadDenied, RuleKind::kAccess, tx.task, kEperm);
  }
}

// Drops the verdict's writes from write `count` (at byte `bytes`) on.
// Inlined, as begin_tx: the check's own path pays for no call.
__attribute__((always_inline)) inline void CheckerState::truncate_emits(uint32_t count,
                                                                        uint32_t bytes) {
  tx_.out->emit_count = static_cast<uint8_t>(count);
  tx_.out->emit_bytes_used = static_cast<uint16_t>(bytes);
}

// A fresh scratch for one check (or safe state) answering into `out`.
__attribute__((always_inline)) inline void CheckerState::begin_tx(Verdict* out) {
  tx_.out = out;
  tx_.outcome_count = 0;
  tx_.overflow = tx_.emit_failed = tx_.any_pending = false;
  tx_.undo_count = tx_.shadow_count = 0;
  tx_.undo_device = tx_.shadow_device = kNone;
  __builtin_memset(tx_.pending_state, 0, sizeof(tx_.pending_state));
  tx_.staged_command = kNone;
  tx_.staged_index = 0;
}

bool CheckerState::emit(const uint8_t* bytes, uint32_t len) {
  Verdict& v = *tx_.out;
  if (v.emit_count >= kMaxEmits || len > kMaxEmitBytes - v.emit_bytes_used) {
    tx_.emit_failed = true;
    return false;
  }
  uint8_t* to = v.emit_bytes + v.emit_bytes_used;
  // A register and its value (the common write) without a call for two bytes.
  len == 2 ? __builtin_memcpy(to, bytes, 2) : __builtin_memcpy(to, bytes, len);
  v.emit_len[v.emit_count++] = static_cast<uint16_t>(len);
  v.emit_bytes_used = static_cast<uint16_t>(v.emit_bytes_used + len);
  return true;
}

void CheckerState::undo_save(uint16_t dev, uint8_t reg) {
  if (dev != tx_.undo_device) {
    tx_.undo_device = dev;
    __builtin_memset(tx_.saved, 0, sizeof(tx_.saved));
  }
  if (bit_test(tx_.saved, reg)) return;
  if (tx_.undo_count >= kMaxRegisters) {
    tx_.overflow = true;
    return;
  }
  bit_set(tx_.saved, reg);
  const DeviceState& s = state_[dev];
  tx_.undo[tx_.undo_count++] =
      Undo{dev, reg, s.staged[reg], s.staged_task[reg], bit_test(s.staged_bits, reg)};
}

void CheckerState::store_shadow(uint16_t dev, uint16_t command, uint8_t reg, uint8_t value) {
  DeviceState& s = state_[dev];
  if (dev != tx_.shadow_device) {
    tx_.shadow_device = dev;
    __builtin_memset(tx_.shadow_saved, 0, sizeof(tx_.shadow_saved));
  }
  auto put = [&](uint8_t r) {  // journals a change only (once per register); a rewrite costs none
    if (s.shadow[r] == value) return;
    if (!bit_test(tx_.shadow_saved, r)) {
      bit_set(tx_.shadow_saved, r);
      tx_.overflow |= tx_.shadow_count >= kMaxRegisters;
      if (tx_.shadow_count < kMaxRegisters)
        tx_.shadow_undo[tx_.shadow_count++] = {dev, r, s.shadow[r]};
    }
    s.shadow[r] = value;
  };
  put(reg);
  const DeviceRecord& d = devices_[dev];
  if (d.broadcast == d.broadcast_target || command != d.command_first + d.broadcast) return;
  const CommandRecord& from = commands_[command];
  const CommandRecord& to = commands_[d.command_first + d.broadcast_target];
  const uint32_t q = static_cast<uint32_t>(reg - from.match);  // offset in the group
  for (uint32_t n = 0; n < to.repeat; ++n) put(static_cast<uint8_t>(to.match + n * to.stride + q));
}

void CheckerState::rollback() {
  for (uint32_t i = tx_.shadow_count; i-- > 0;) {
    state_[tx_.shadow_undo[i].device].shadow[tx_.shadow_undo[i].reg] = tx_.shadow_undo[i].value;
  }
  for (uint32_t i = tx_.undo_count; i-- > 0;) {
    const Undo& u = tx_.undo[i];
    DeviceState& s = state_[u.device];
    s.staged[u.reg] = u.staged;
    s.staged_task[u.reg] = u.staged_task;
    bit_clear(s.staged_bits, u.reg);
    s.staged_bits[u.reg / 32] |= uint32_t{u.staged_bit} << (u.reg % 32);
  }
  tx_.undo_count = tx_.shadow_count = 0;
  tx_.undo_device = tx_.shadow_device = kNone;
}

LastCommand& CheckerState::last(uint16_t command, uint8_t index) {
  // The verifier sized the history so that every (command, channel) has a slot.
  const CommandRecord& c = commands_[command];
  const uint32_t channel = index < c.repeat ? index : 0;
  return last_[last_first_[command] + channel];
}

bool CheckerState::record_violation(uint16_t dev, uint64_t now_us) {
  const DeviceRecord& d = devices_[dev];
  if (d.latch_mode == LatchMode::kOff) return false;
  DeviceState& s = state_[dev];
  s.violations[s.violation_next] = now_us;
  s.violation_next = static_cast<uint8_t>((s.violation_next + 1) % kMaxLatchCount);
  if (s.violation_count < kMaxLatchCount) ++s.violation_count;
  if (s.violation_count < d.latch_count) return false;
  const uint32_t oldest = (s.violation_next + kMaxLatchCount - d.latch_count) % kMaxLatchCount;
  const uint64_t t0 = s.violations[oldest];
  if (now_us >= t0 && now_us - t0 > d.latch_window_us) return false;
  s.latched = true;
  return true;
}

void CheckerState::reset_latch(uint16_t device) {
  if (device >= device_count_) return;
  DeviceState& s = state_[device];
  s.latched = false;
  s.violation_count = 0;
  s.violation_next = 0;
}

bool CheckerState::latched(uint16_t device) const {
  return device < device_count_ && state_[device].latched;
}

static void init_verdict(Verdict* out, const Transaction* tx) {
  out->decision = Decision::kReject;
  out->reason = Reason::kNotLoaded;
  out->rule_kind = RuleKind::kNoRule;
  out->reply_errno = kEperm;
  out->rule = kNone;
  out->device = kNone;
  out->addr = tx ? tx->addr : 0;
  out->bus = tx ? tx->bus : 0;
  out->emit_count = 0;
  out->emit_bytes_used = 0;
}

AuditRecord audit_record(const Transaction& tx, uint16_t device, uint16_t command,
                         Decision decision, Reason reason) {
  AuditRecord r{};
  r.time_us = tx.now_us;
  r.job = tx.job;
  r.task = tx.task;
  r.device = device;
  r.command = command;
  r.rule = kNone;
  r.rule_kind = RuleKind::kNoRule;
  r.decision = decision;
  r.reason = reason;
  r.bus = tx.bus;
  r.addr = tx.addr;
  r.original_len = static_cast<uint16_t>(tx.len);
  r.original = tx.bytes;
  return r;
}

Subst template_subst(const TemplateRecord& t) {
  Subst s{};
  s.active = true;
  s.command = t.command;
  s.index = t.index;
  s.set_mask = t.set_mask;
  copy_fields(s.values, t.values);
  return s;
}

void CheckerState::audit(const Transaction& tx, const Outcome& o) {
  if (host_.audit == nullptr) return;
  AuditRecord r = audit_record(tx, o.device, o.command, o.decision, o.reason);
  r.rule = o.rule;
  r.rule_kind = o.rule_kind;
  r.index = o.index;
  for (uint32_t i = 0; i < o.field_count; ++i) r.fields[i] = o.fields[i];
  r.field_count = o.field_count;
  if (o.decision == Decision::kFailsafe && o.emit_len != 0) {
    r.substitute = tx_.out->emit_bytes + o.emit_offset;
    r.substitute_len = o.emit_len;
  }
  host_.audit(host_.context, &r);
}

void CheckerState::check(const Transaction& tx, Verdict* out) {
  init_verdict(out, &tx);
  begin_tx(out);
  latch_event_ = false;
  latch_device_ = kNone;
  now_us_ = tx.now_us;
  if (journal_.active && journal_.first.task == kNoTask) {
    journal_.first = tx;
    journal_.first.bytes = nullptr;
    journal_.first.len = 0;
  }
  if (++epoch_ == 0) {  // wrapped: forget every memo so none looks current
    __builtin_memset(signal_memo_, 0, sizeof(signal_memo_));
    __builtin_memset(sample_memo_, 0, sizeof(sample_memo_));
    epoch_ = 1;
  }

  auto refuse_all = [&](uint16_t dev, Reason reason, uint8_t err) {
    Outcome* o = new_outcome(dev);
    if (o != nullptr) decide(*o, Decision::kReject, reason, RuleKind::kNoRule, kNone, err);
    finish(tx, out);
  };
  if (!loaded_) return refuse_all(kNone, Reason::kNotLoaded, kEperm);
  if (tx.task == kNoTask || tx.task >= task_count_) {
    return refuse_all(kNone, Reason::kUnknownTask, kEperm);
  }

  uint16_t targets[kMaxDevices];
  const uint32_t target_count = find_targets(tx, targets);
  if (reserved_address(tx, target_count)) {
    return refuse_all(kNone, Reason::kReservedAddress, kEnxio);
  }
  const bool general_call = tx.addr == 0 && tx.ten_bit == 0;
  general_call_ = general_call;
  if (general_call && (tx.kind != TxKind::kWrite || tx.len != 1 || target_count == 0)) {
    // Every device on the bus takes a general call, each in its own way: only
    // a declared one-byte general-call command (PCA9685 SWRST) is modelled.
    Outcome* o = new_outcome(kNone);
    if (o != nullptr)
      decide(*o, Decision::kIgnore, Reason::kGeneralCall, RuleKind::kNoRule, kNone, 0);
    finish(tx, out);
    return;
  }
  if (target_count == 0) return refuse_all(kNone, Reason::kUnknownDevice, kEnxio);
  out->device = targets[0];
  if (tx.len > kMaxWriteBytes) return refuse_all(targets[0], Reason::kTooLong, kEinval);
  if (tx.len != 0 && tx.bytes == nullptr) {
    return refuse_all(targets[0], Reason::kMalformed, kEinval);
  }
  for (uint32_t i = 0; i < target_count; ++i) {
    if (!journal_device(targets[i])) return refuse_all(targets[0], Reason::kTooLong, kEinval);
  }

  update_window(tx);
  for (uint32_t i = 0; i < target_count; ++i) check_device(tx, targets[i]);
  bool broadcast = false;
  if (general_call) broadcast = resolve_general_call(tx, out);
  finish(tx, out);
  if (broadcast && out->decision == Decision::kAllow) out->addr = 0;
}

// 0x01-0x07 and 0x78-0x7F are reserved (CBUS, Hs-mode master codes, the
// first byte of a 10-bit address, device ID): refused unless the policy
// declares a device there (some do: a line follower at 0x06), and 0x78-0x7B
// always on a bus with a 10-bit device, whose address they would begin.
bool CheckerState::reserved_address(const Transaction& tx, uint32_t target_count) const {
  if (tx.ten_bit != 0 || tx.addr == 0 || (tx.addr > 0x07 && tx.addr < 0x78)) return false;
  if (target_count == 0) return true;
  if (tx.addr > 0x7B) return false;
  for (uint32_t i = 0; i < device_count_; ++i) {
    if (devices_[i].bus == tx.bus && devices_[i].ten_bit != 0) return true;
  }
  return false;
}

// The devices a transaction addresses: the device at (bus, addr), an address
// alias, or every listener of a general call.
uint32_t CheckerState::find_targets(const Transaction& tx, uint16_t* targets) const {
  uint32_t count = 0;
  if (tx.addr == 0 && tx.ten_bit == 0) {
    for (uint32_t i = 0; i < alias_count_; ++i) {
      const AliasRecord& a = aliases_[i];
      if (a.kind == AliasKind::kGeneralCall && a.bus == tx.bus && count < kMaxDevices) {
        targets[count++] = a.device;
      }
    }
    return count;
  }
  for (uint32_t i = 0; i < device_count_; ++i) {
    const DeviceRecord& d = devices_[i];
    if (d.bus == tx.bus && d.addr == tx.addr && d.ten_bit == (tx.ten_bit ? 1 : 0)) {
      targets[0] = static_cast<uint16_t>(i);
      return 1;
    }
  }
  if (tx.ten_bit != 0) return 0;
  for (uint32_t i = 0; i < alias_count_; ++i) {
    const AliasRecord& a = aliases_[i];
    if (a.kind == AliasKind::kAddress && a.bus == tx.bus && a.addr == tx.addr) {
      targets[0] = a.device;
      return 1;
    }
  }
  return 0;
}

// A general call reaches every device on the bus, so (docs/core.md):
// - every listener allows it as it is: the bytes go to the general-call address;
// - a listener's FAIL-SAFE (a substitute, or its safe state on latching) is
//   written to that listener's own address, and nothing to the general call:
//   the policy's response holds whatever address the task chose. One verdict
//   has one address and the other listeners' state must not move, so when
//   another listener needs a substitute too, or would have had registers
//   written, the call is rejected instead (EPERM, nothing written);
// - otherwise the usual combination (reject over ignore over fail-safe) decides.
// Returns true if the verdict is the broadcast itself.
bool CheckerState::resolve_general_call(const Transaction& tx, Verdict* out) {
  Verdict& v = *out;
  uint32_t substituting = 0;
  Outcome* sub = nullptr;
  bool all_allow = true;
  bool written = false;  // an allowed command has writes
  for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
    Outcome& o = tx_.outcomes[i];
    if (o.decision == Decision::kFailsafe) {
      ++substituting;
      sub = &o;
    }
    all_allow = all_allow && o.decision == Decision::kAllow;
    written = written || (o.decision == Decision::kAllow && o.emit_len != 0);
  }
  if (all_allow) {
    truncate_emits(0, 0);
    if (tx.kind == TxKind::kWrite && !emit(tx.bytes, tx.len)) tx_.overflow = true;
    return true;
  }
  if (substituting > 1 || (sub != nullptr && written)) {
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      Outcome& o = tx_.outcomes[i];
      if (o.decision == Decision::kFailsafe) {
        decide(o, Decision::kReject, o.reason, o.rule_kind, o.rule, kEperm);
      }
    }
    return false;
  }
  if (sub != nullptr && !latch_event_) {
    // Keep only the substitute's writes, moved to the front, addressed to its device.
    uint32_t count = 0;
    uint32_t used = 0;
    for (; sub->emit_index + count < v.emit_count && used < sub->emit_len; ++count) {
      used += v.emit_len[sub->emit_index + count];
    }
    __builtin_memmove(v.emit_len, v.emit_len + sub->emit_index, sizeof(v.emit_len[0]) * count);
    __builtin_memmove(v.emit_bytes, v.emit_bytes + sub->emit_offset, used);
    truncate_emits(count, used);
    sub->emit_offset = 0;
    sub->emit_index = 0;
    // Commands allowed without writes (staged) do not reach the bus either.
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      Outcome& o = tx_.outcomes[i];
      if (o.decision == Decision::kAllow) o.bus_command = kNone;
    }
  }
  if (sub != nullptr) v.device = sub->device;
  return false;
}

void CheckerState::check_device(const Transaction& tx, uint16_t dev) {
  if (tx.kind == TxKind::kRead || tx.kind == TxKind::kQuick) {
    if (Outcome* o = new_outcome(dev)) decide_read(*o, tx, dev);
    return;
  }
  if (tx.kind != TxKind::kWrite) return refuse(dev, Reason::kMalformed, kEinval);
  if (devices_[dev].profile == Profile::kFrame) {
    check_frame(tx, dev);
  } else {
    check_register_map(tx, dev);
  }
}

// Applies a rule's static response to `o`: ignore, reject, or fail-safe with
// the rule's template (ignore when it has none).
void CheckerState::respond(Outcome& o, Response response, uint8_t err, uint16_t template_id,
                           Reason reason, RuleKind kind, uint16_t rule) {
  if (response == Response::kReject) {
    decide(o, Decision::kReject, reason, kind, rule, err);
    return;
  }
  if (response == Response::kFailsafe && template_id != kNone) {
    decide(o, Decision::kFailsafe, reason, kind, rule, 0);
    if (!emit_substitute(template_subst(templates_[template_id]), o)) {
      decide(o, Decision::kIgnore, Reason::kEncodeFailed, kind, rule, 0);
    }
    return;
  }
  decide(o, Decision::kIgnore, reason, kind, rule, 0);
}

void CheckerState::evaluate(const Transaction& tx, Outcome& o) {
  const Decoded& d = decoded_;
  bool unrepaired = false;  // for LatchMode::kHoldSafeUnrepaired
  uint64_t rates_hit = 0;   // the rate rules that select this command
  const uint16_t dev = d.device;
  o.command = d.command;
  o.index = d.index;
  o.field_count = d.field_count;
  copy_fields(o.fields, d.fields);
  const CommandRecord& cmd = commands_[d.command];
  if (cmd.command_class == CommandClass::kQuery) return decide_read(o, tx, dev);
  if (cmd.command_class == CommandClass::kForbidden) {
    decide(o, Decision::kReject, Reason::kForbiddenCommand, RuleKind::kNoRule, kNone, kEperm);
  } else if (((access_[tx.task].actuate_devices >> dev) & 1u) == 0) {
    decide(o, Decision::kReject, Reason::kAccessDenied, RuleKind::kAccess, tx.task, kEperm);
  } else if (state_[dev].latched) {
    // Held in its safe state: nothing acts. A command a rate rule refuses
    // now is still refused with that rule's errno (the program learns its
    // call is forbidden, as it would unlatched); others are ignored.
    const uint16_t r = refusing_rate(tx, d);
    if (r != kNone) {
      decide(o, Decision::kReject, Reason::kRateExceeded, RuleKind::kRate, r,
             rates_[r].reply_errno);
    } else {
      decide(o, Decision::kIgnore, Reason::kLatched, RuleKind::kLatch, dev, 0);
    }
    return;  // already held: no new violation
  } else {
    bool decided = false;
    const uint64_t rates = tx.task < kMaxTasks && dev < kMaxDevices ? rates_of_[tx.task][dev] : 0;
    for (uint64_t bits = rates; bits != 0; bits &= bits - 1) {
      const uint32_t r = static_cast<uint32_t>(__builtin_ctzll(bits));
      const RateRecord& rr = rates_[r];
      if (!selects(rr, tx, d)) continue;
      rates_hit |= uint64_t{1} << r;
      if (!decided && rate_used_[r] >= rr.max_per_job) {
        respond(o, rr.response, rr.reply_errno, rr.template_id, Reason::kRateExceeded,
                RuleKind::kRate, static_cast<uint16_t>(r));
        decided = true;
      }
    }
    if (!decided) {
      Env env{&tx, &d, kNone, nullptr};
      unrepaired = true;  // an invariant decides from here on, unless it repairs
      Subst subst{};
      bool stop = false;
      for (uint32_t w = 0; w < kInvariantWords && !stop && d.command < kMaxCommandDefs; ++w) {
        for (uint64_t bits = invariants_of_[d.command][w]; bits != 0; bits &= bits - 1) {
          const uint32_t i = w * 64 + static_cast<uint32_t>(__builtin_ctzll(bits));
          const InvariantRecord& inv = invariants_[i];
          env.invariant = static_cast<uint16_t>(i);
          subst.active = false;
          env.subst = &subst;
          int64_t unused = 0;
          const Exit exit = run(inv.code_first, inv.code_len, env, &unused);
          const uint16_t rule = static_cast<uint16_t>(i);
          if (exit == Exit::kPass) continue;
          if (exit == Exit::kFail) {
            respond(o, inv.response, inv.reply_errno, inv.template_id, Reason::kInvariantViolated,
                    RuleKind::kInvariant, rule);
          } else if (exit == Exit::kFailSubst) {
            decide(o, Decision::kFailsafe, Reason::kInvariantViolated, RuleKind::kInvariant, rule,
                   0);
            if (!emit_substitute(subst, o)) {
              decide(o, Decision::kIgnore, Reason::kEncodeFailed, RuleKind::kInvariant, rule, 0);
            } else {
              unrepaired = false;  // the device got the command the policy expects
            }
          } else {
            // A fault is a violation: fail closed with the invariant's template.
            const Reason why =
                exit == Exit::kUnavailable ? Reason::kSignalUnavailable : Reason::kProgramFault;
            respond(o, Response::kFailsafe, 0, inv.template_id, why, RuleKind::kInvariant, rule);
          }
          stop = true;  // the first invariant that does not pass decides
          break;
        }
      }
    }
  }
  // Commands dropped by a rate limit do not count toward the latch: a burst
  // is already held to its budget, and latching on it would hand the
  // attacker the stop it is after while the honest commands are fine. A
  // device latching on unrepaired violations only also lets pass what left
  // it on the policy's line: an expected substitute, a refused command of a
  // task that may not drive it, a forbidden command.
  const bool counts = devices_[dev].latch_mode != LatchMode::kHoldSafeUnrepaired || unrepaired;
  if (o.decision != Decision::kAllow && o.reason != Reason::kRateExceeded && counts &&
      record_violation(dev, tx.now_us)) {
    // The K-th violation in the window: drive the safe state once, hold it.
    truncate_emits(o.emit_index, o.emit_offset);
    tx_.emit_failed = false;
    latch_event_ = true;
    latch_device_ = dev;
    if (emit_safe_state(dev)) {
      decide(o, Decision::kFailsafe, Reason::kLatched, RuleKind::kLatch, dev, 0);
      o.emit_len = static_cast<uint16_t>(tx_.out->emit_bytes_used - o.emit_offset);
      o.bus_command = kNone;
    } else {
      truncate_emits(o.emit_index, o.emit_offset);
      decide(o, Decision::kIgnore, Reason::kLatched, RuleKind::kLatch, dev, 0);
    }
  }
  if (o.reason != Reason::kLatched) count_acting(tx, o, rates_hit);
}

bool CheckerState::emit_safe_state(uint16_t dev) {
  const DeviceRecord& d = devices_[dev];
  if (d.safe_count == 0) return false;
  for (uint32_t t = d.safe_first; t < d.safe_first + d.safe_count; ++t) {
    Encoded e;
    if (!build_substitute(template_subst(templates_[t]), nullptr, dev, e)) return false;
    if (!emit_encoded(dev, nullptr, e)) return false;
  }
  // The mechanism is where the safe state put it: a device-scope sequence
  // goes on from there (settled with the verdict, as a check's state words).
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (invariants_[i].device != dev || invariants_[i].after_safe == 0) continue;
    bit_set(tx_.pending_state, i);
    tx_.any_pending = true;
    pending_state_[i] = invariants_[i].after_safe - 1;
  }
  return true;
}

bool CheckerState::safe_state(uint16_t device, Verdict* out, bool apply) {
  init_verdict(out, nullptr);
  if (!loaded_ || device >= device_count_) return false;
  begin_tx(out);
  out->device = device;
  out->addr = devices_[device].addr;
  out->bus = devices_[device].bus;
  if (!emit_safe_state(device)) {
    rollback();
    truncate_emits(0, 0);
    return false;
  }
  if (!apply) rollback();  // the shadows it wrote; its state words stay pending
  for (uint32_t i = 0; apply && i < invariant_count_; ++i) {  // device scope: no task's word
    if (bit_test(tx_.pending_state, i)) state_words_[i] = pending_state_[i];
  }
  out->decision = Decision::kFailsafe;
  out->reason = state_[device].latched ? Reason::kLatched : Reason::kAllowed;
  out->rule_kind = RuleKind::kLatch;
  out->rule = device;
  out->reply_errno = 0;
  return true;
}

void CheckerState::finish(const Transaction& tx, Verdict* out) {
  Decision decision = Decision::kAllow;
  const Outcome* decider = nullptr;
  if (journal_.active && journal_.history_count + tx_.outcome_count > kMaxTransferHistory) {
    tx_.overflow = true;  // its history could not be undone with the transfer
  }
  if (tx_.overflow || tx_.emit_failed) {
    // Too many commands, undo entries or emitted bytes: refuse it all.
    Outcome* o = tx_.outcome_count < kMaxCommandsPerTransaction
                     ? new_outcome(out->device)
                     : &tx_.outcomes[tx_.outcome_count - 1];
    decide(*o, Decision::kReject, Reason::kTooLong, RuleKind::kNoRule, kNone, kEinval);
    decision = Decision::kReject;
    decider = o;
  } else if (latch_event_) {
    // A device latched inside this transaction: its safe state is all that is written.
    truncate_emits(0, 0);
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      Outcome& o = tx_.outcomes[i];
      if (o.rule_kind == RuleKind::kLatch && o.device == latch_device_) {
        decider = &o;
        break;
      }
    }
    decision = decider->decision;
    if (decision == Decision::kFailsafe) {
      Outcome& o = const_cast<Outcome&>(*decider);
      o.emit_offset = 0;
      o.emit_index = 0;
      if (!emit_safe_state(latch_device_)) decision = Decision::kIgnore;
      o.emit_len = out->emit_bytes_used;
    }
  } else {
    // Reject over ignore over fail-safe over allow; the first of the
    // strongest decides.
    uint32_t strongest = 0;
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      const uint32_t s = decision_strength(tx_.outcomes[i].decision);
      if (s > strongest) {
        strongest = s;
        decider = &tx_.outcomes[i];
      }
    }
    if (decider != nullptr) decision = decider->decision;
    if (decider == nullptr && tx_.outcome_count != 0) decider = &tx_.outcomes[0];
  }

  out->decision = decision;
  if (decider != nullptr) {
    out->reason = decider->reason;
    out->rule_kind = decider->rule_kind;
    out->rule = decider->rule;
    out->reply_errno = decision == Decision::kReject ? decider->reply_errno : 0;
  } else {
    out->reason = Reason::kStaged;  // only staged register writes
    out->rule_kind = RuleKind::kNoRule;
    out->rule = kNone;
    out->reply_errno = 0;
  }
  if (out->device != kNone && out->device < device_count_) {
    out->addr = devices_[out->device].addr;
    out->bus = devices_[out->device].bus;
  }

  if (!writes(decision)) truncate_emits(0, 0);
  settle_model(tx, decision);

  if (journal_.active && writes(decision)) ++journal_.acted;
  // Audit: one record per decoded command (commands allowed on their own but
  // dropped with their transaction carry the transaction's decision).
  if (host_.audit == nullptr) return;
  if (tx_.outcome_count == 0) {
    Outcome o{};
    o.device = out->device;
    o.command = tx_.staged_command;
    o.index = tx_.staged_index;
    o.decision = Decision::kAllow;
    o.reason = Reason::kStaged;
    o.rule = kNone;
    audit(tx, o);
    return;
  }
  for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
    Outcome o = tx_.outcomes[i];
    if (!writes(decision) && writes(o.decision) && decider != nullptr) {
      o.decision = decision;
      o.reason = decider->reason;
      o.rule_kind = decider->rule_kind;
      o.rule = decider->rule;
    }
    audit(tx, o);
  }
}

}  // namespace contego::core::internal

namespace contego::core {

using internal::CheckerState;

static_assert(sizeof(CheckerState) <= kCheckerStateBytes, "raise kCheckerStateBytes (checker.h)");
static_assert(sizeof(void*) != 8 || kCheckerStateBytes - sizeof(CheckerState) < 64,
              "lower kCheckerStateBytes (checker.h)");
static_assert(alignof(CheckerState) <= kCheckerStateAlign, "raise kCheckerStateAlign");

Checker::Checker() { new (storage_, internal::Place{}) CheckerState(); }
LoadResult Checker::load(const uint8_t* image, uint32_t size) { return state().load(image, size); }
bool Checker::loaded() const { return state().loaded_; }
void Checker::set_host(const Host& host) { state().host_ = host; }
void Checker::check(const Transaction& tx, Verdict* out) { state().check(tx, out); }
bool Checker::safe_state(uint16_t device, Verdict* out, bool apply) {
  return state().safe_state(device, out, apply);
}
void Checker::reset_latch(uint16_t device) { state().reset_latch(device); }
uint32_t Checker::end_session(uint16_t task) { return state().end_session(task); }
bool Checker::latched(uint16_t device) const { return state().latched(device); }
void Checker::begin_transfer() { state().begin_transfer(); }
void Checker::commit_transfer() { state().commit_transfer(); }
void Checker::abort_transfer(Decision decision) { state().abort_transfer(decision); }
bool Checker::in_transfer() const { return state().journal_.active; }
bool Checker::shadow(uint16_t device, uint8_t reg, uint8_t* value) const {
  return state().shadow(device, reg, value);
}
uint32_t Checker::model_crc() const { return state().model_crc(); }
Checker::CarryResult Checker::carry_from(const Checker& old, const CarryMap& map) {
  return state().carry_from(old.state(), map);
}
Checker::RecordCounts Checker::record_counts() const {
  const CheckerState& s = state();
  return {s.task_count_, s.device_count_, s.command_count_, s.rate_count_, s.invariant_count_};
}
uint32_t Checker::worst_case_cost() const { return state().worst_case_cost_; }
uint64_t Checker::executed_instructions() const { return state().executed_; }
uint32_t Checker::task_count() const { return state().task_count_; }
uint32_t Checker::device_count() const { return state().device_count_; }
const TaskRecord& Checker::task(uint16_t id) const { return state().tasks_[id]; }
const DeviceRecord& Checker::device(uint16_t id) const { return state().devices_[id]; }
const AccessRecord& Checker::access(uint16_t task) const { return state().access_[task]; }

}  // namespace contego::core
