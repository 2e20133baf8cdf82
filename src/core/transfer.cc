// Transfers: several check() calls as one unit. A journal keeps, from the
// first change of each, the device models, state words and history slots the
// transfer's checks change, so abort_transfer() puts them back exactly.
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {

static_assert(kMaxDevices <= 32, "Journal::saved_devices is one 32-bit word");

void CheckerState::begin_transfer() {
  journal_.active = true;
  journal_.acted = 0;
  journal_.saved_devices = 0;
  journal_.device_count = 0;
  journal_.history_count = 0;
  __builtin_memset(journal_.saved_state, 0, sizeof(journal_.saved_state));
  journal_.first = Transaction{};
  journal_.first.task = kNoTask;
}

void CheckerState::commit_transfer() { journal_.active = false; }

bool CheckerState::journal_device(uint16_t dev) {
  if (!journal_.active || ((journal_.saved_devices >> dev) & 1u) != 0) return true;
  // Only a register map has a model to put back; copying a frame device's
  // unused 800 bytes on every check of the rover cost cache lines for nothing.
  if (devices_[dev].profile != Profile::kRegisterMap) {
    journal_.saved_devices |= 1u << dev;
    return true;
  }
  if (journal_.device_count >= kMaxTransferDevices) return false;
  ModelCopy& c = journal_.devices[journal_.device_count++];
  c.device = dev;
  __builtin_memcpy(c.shadow, state_[dev].shadow, kModelBytes);
  __builtin_memset(c.dropped_bits, 0, sizeof(c.dropped_bits));
  journal_.saved_devices |= 1u << dev;
  return true;
}

void CheckerState::drop_staged(uint16_t dev, uint32_t reg) {
  bit_clear(state_[dev].staged_bits, reg);
  mark_dropped(dev, reg);
}

void CheckerState::mark_dropped(uint16_t dev, uint32_t reg) {
  for (uint32_t i = 0; journal_.active && i < journal_.device_count; ++i) {
    if (journal_.devices[i].device == dev) bit_set(journal_.devices[i].dropped_bits, reg);
  }
}

// The caller made sure there is room (finish() refuses a check that could overflow).
void CheckerState::journal_history(LastCommand& slot) {
  if (!journal_.active || journal_.history_count >= kMaxTransferHistory) return;
  HistoryCopy& h = journal_.history[journal_.history_count++];
  h.slot = static_cast<uint16_t>(&slot - last_);
  h.last = slot;
}

// A transfer is one task's: the task-scoped words it saves are that task's.
void CheckerState::journal_state(uint32_t invariant, uint16_t task) {
  if (!journal_.active || bit_test(journal_.saved_state, invariant)) return;
  bit_set(journal_.saved_state, invariant);
  journal_.state_task = task;
  journal_.state_words[invariant] = state_word(invariant, task);
}

int64_t& CheckerState::state_word(uint32_t i, uint16_t task) {
  if (invariants_[i].scope == StateScope::kDevice || task >= kMaxTasks) return state_words_[i];
  return task_state_words_[task][i];
}

// After the decision: a verdict that writes commits the transaction's state
// words and history; one that does not undoes its register changes.
void CheckerState::settle_model(const Transaction& tx, Decision decision) {
  if (!writes(decision)) {
    rollback();
    // A group whose commit was checked and refused loses the task's staged bytes.
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      const Outcome& o = tx_.outcomes[i];
      if (o.group_len == 0 || o.command == kNone || o.device >= device_count_) continue;
      for (uint32_t r = o.base_reg; r < o.base_reg + o.group_len; ++r) {
        if (state_[o.device].staged_task[r] == tx.task) drop_staged(o.device, r);
      }
    }
  } else {
    // Staged bytes this check displaced are gone for good now that it acts
    // (an aborted transfer does not bring them back), audited in their
    // task's name: another task's, or the task's own staged again before its
    // group completed (a driver that never completes one says so at once).
    uint32_t last_group = 0xFFFFFFFFu;
    for (uint32_t i = 0; i < tx_.undo_count; ++i) {
      const Undo& u = tx_.undo[i];
      const bool own = u.staged_task == tx.task;
      if (!u.staged_bit || (own && !bit_test(state_[u.device].staged_bits, u.reg))) continue;
      mark_dropped(u.device, u.reg);
      audit_staging_drop(tx, u.device, u.reg, u.staged_task,
                         own ? Reason::kStagedIncomplete : Reason::kStagingConflict, last_group);
    }
    for (uint32_t word = 0; tx_.any_pending && word < kMaxInvariants / 32; ++word) {
      for (uint32_t bits = tx_.pending_state[word]; bits != 0; bits &= bits - 1) {
        const uint32_t i = word * 32 + static_cast<uint32_t>(__builtin_ctz(bits));
        journal_state(i, tx.task);
        state_word(i, tx.task) = pending_state_[i];
      }
    }
    for (uint32_t i = 0; i < tx_.outcome_count; ++i) {
      const Outcome& o = tx_.outcomes[i];
      if (o.bus_command == kNone || !writes(o.decision)) continue;
      LastCommand& l = last(o.bus_command, o.bus_index);
      journal_history(l);
      l.valid = true;
      l.time_us = tx.now_us;
      copy_fields(l.fields, o.bus_fields);
      const CommandRecord& c = commands_[o.bus_command];
      if (c.group_len == 0 && devices_[o.device].profile == Profile::kRegisterMap) {
        // A general-call command (software reset) reached the device: its
        // registers are back at their power-on values, nothing is staged.
        DeviceState& s = state_[o.device];
        __builtin_memcpy(s.shadow, s.power_on, kMaxRegisters);
        __builtin_memset(s.staged_bits, 0, sizeof(s.staged_bits));
      }
    }
  }
}

uint32_t CheckerState::end_session(uint16_t task) {
  if (!loaded_ || task >= task_count_) return 0;
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (invariants_[i].scope == StateScope::kSession) {
      task_state_words_[task][i] = 0;
    }
  }
  uint32_t dropped = 0;
  for (uint32_t d = 0; d < device_count_; ++d) {
    DeviceState& s = state_[d];
    for (uint32_t reg = 0; reg < kMaxRegisters; ++reg) {
      if (!bit_test(s.staged_bits, reg) || s.staged_task[reg] != task) continue;
      bit_clear(s.staged_bits, reg);
      ++dropped;
    }
  }
  return dropped;
}

void CheckerState::abort_transfer(Decision decision) {
  if (!journal_.active) return;
  journal_.active = false;
  for (uint32_t i = journal_.history_count; i-- > 0;) {
    last_[journal_.history[i].slot] = journal_.history[i].last;
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (bit_test(journal_.saved_state, i)) {
      state_word(i, journal_.state_task) = journal_.state_words[i];
    }
  }
  for (uint32_t i = 0; i < journal_.device_count; ++i) {
    const ModelCopy& c = journal_.devices[i];
    DeviceState& s = state_[c.device];
    __builtin_memcpy(s.shadow, c.shadow, kModelBytes);
    for (uint32_t w = 0; w < kMaxRegisters / 32; ++w) s.staged_bits[w] &= ~c.dropped_bits[w];
  }
  if (journal_.acted == 0 || host_.audit == nullptr) return;
  // Checks already audited as acting did not: say so in the same log.
  const AuditRecord r =
      audit_record(journal_.first, kNone, kNone, decision, Reason::kTransferDropped);
  host_.audit(host_.context, &r);
}

bool CheckerState::shadow(uint16_t device, uint8_t reg, uint8_t* value) const {
  if (!register_map(device)) return false;
  *value = state_[device].shadow[reg];
  return true;
}

uint32_t CheckerState::model_crc() const {
  // CRC-32 chained over the pieces (crc32 of a piece seeded by the previous).
  uint8_t buf[4 + kMaxRegisters];
  uint32_t crc = 0;
  auto mix = [&](const void* p, uint32_t len) {
    __builtin_memcpy(buf, &crc, 4);  // little-endian (verifier.cc asserts it), as the image
    __builtin_memcpy(buf + 4, p, len);
    crc = crc32(buf, 4 + len);
  };
  for (uint32_t d = 0; d < device_count_; ++d) {
    const DeviceState& s = state_[d];
    mix(s.shadow, kMaxRegisters);
    mix(s.staged, kMaxRegisters);
    mix(s.staged_task, kMaxRegisters);
    mix(s.staged_bits, sizeof(s.staged_bits));
  }
  for (uint32_t i = 0; i < kMaxHistorySlots; ++i) {
    const LastCommand& l = last_[i];
    const uint8_t valid = l.valid ? 1 : 0;
    mix(&l.time_us, sizeof(l.time_us));
    mix(l.fields, sizeof(l.fields));
    mix(&valid, 1);
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) mix(&state_words_[i], sizeof(state_words_[i]));
  for (uint32_t t = 0; t < task_count_; ++t) {
    for (uint32_t i = 0; i < invariant_count_; ++i) {
      mix(&task_state_words_[t][i], sizeof(task_state_words_[t][i]));
    }
  }
  return crc;
}

}  // namespace contego::core::internal
