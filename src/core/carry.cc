// Reload in place: a freshly loaded checker takes over the run-time model of
// the one it replaces, record by record as the host pairs them. What a
// program did before the reload keeps counting after it: a latch stays
// latched, a sequence keeps its position, a job's rate count and a register
// group half written go on. Nothing unpaired is guessed at: it starts as
// after load().
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {
namespace {

// A paired id: kNone (not paired) or inside the old table.
bool in_range(const uint16_t* map, uint32_t i, uint32_t old_count) {
  return map == nullptr || map[i] == kNone || map[i] < old_count;
}

uint16_t pair_of(const uint16_t* map, uint32_t i) { return map == nullptr ? kNone : map[i]; }

uint32_t channels(const CommandRecord& c) { return c.repeat > 1 ? c.repeat : 1; }

}  // namespace

bool CheckerState::carry_pairs_agree(const CheckerState& old, const Checker::CarryMap& m) const {
  for (uint32_t t = 0; t < task_count_; ++t) {
    if (!in_range(m.tasks, t, old.task_count_)) return false;
  }
  for (uint32_t d = 0; d < device_count_; ++d) {
    if (!in_range(m.devices, d, old.device_count_)) return false;
    const uint16_t o = pair_of(m.devices, d);
    if (o == kNone) continue;
    const DeviceRecord& a = devices_[d];
    const DeviceRecord& b = old.devices_[o];
    if (a.bus != b.bus || a.addr != b.addr || a.ten_bit != b.ten_bit || a.profile != b.profile) {
      return false;
    }
  }
  for (uint32_t c = 0; c < command_count_; ++c) {
    if (!in_range(m.commands, c, old.command_count_)) return false;
    const uint16_t o = pair_of(m.commands, c);
    if (o == kNone) continue;
    if (pair_of(m.devices, commands_[c].device) != old.commands_[o].device ||
        commands_[c].field_count != old.commands_[o].field_count) {
      return false;
    }
  }
  for (uint32_t r = 0; r < rate_count_; ++r) {
    if (!in_range(m.rates, r, old.rate_count_)) return false;
    const uint16_t o = pair_of(m.rates, r);
    if (o == kNone) continue;
    if (pair_of(m.tasks, rates_[r].task) != old.rates_[o].task ||
        pair_of(m.devices, rates_[r].device) != old.rates_[o].device) {
      return false;
    }
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (!in_range(m.invariants, i, old.invariant_count_)) return false;
    const uint16_t o = pair_of(m.invariants, i);
    if (o == kNone) continue;
    if (pair_of(m.devices, invariants_[i].device) != old.invariants_[o].device ||
        invariants_[i].scope != old.invariants_[o].scope) {
      return false;
    }
  }
  return true;
}

// Shadows, staged writes, violations and the latch of every paired device.
// The image-derived parts (lookup, power-on values) stay this image's.
uint32_t CheckerState::carry_devices(const CheckerState& old, const Checker::CarryMap& m) {
  uint32_t dropped = 0;
  for (uint32_t d = 0; d < device_count_; ++d) {
    const uint16_t o = pair_of(m.devices, d);
    if (o == kNone) continue;
    DeviceState& s = state_[d];
    const DeviceState& from = old.state_[o];
    __builtin_memcpy(s.shadow, from.shadow, sizeof(s.shadow));
    __builtin_memcpy(s.violations, from.violations, sizeof(s.violations));
    s.violation_count = from.violation_count;
    s.violation_next = from.violation_next;
    s.latched = from.latched;
    __builtin_memcpy(s.staged, from.staged, sizeof(s.staged));
    __builtin_memcpy(s.staged_task, from.staged_task, sizeof(s.staged_task));
    __builtin_memcpy(s.staged_bits, from.staged_bits, sizeof(s.staged_bits));
    for (uint32_t reg = 0; reg < kMaxRegisters; ++reg) {
      if (!bit_test(s.staged_bits, reg)) continue;
      // Staged by a task of the new image: its group completes as before.
      uint16_t task = kNone;
      for (uint32_t t = 0; t < task_count_ && task == kNone; ++t) {
        if (pair_of(m.tasks, t) == from.staged_task[reg]) task = static_cast<uint16_t>(t);
      }
      if (task == kNone) {
        bit_clear(s.staged_bits, reg);
        ++dropped;
      } else {
        s.staged_task[reg] = static_cast<uint8_t>(task);
      }
    }
  }
  return dropped;
}

Checker::CarryResult CheckerState::carry_from(const CheckerState& old, const Checker::CarryMap& m) {
  if (!loaded_ || !old.loaded_ || journal_.active || old.journal_.active ||
      !carry_pairs_agree(old, m)) {
    return {false, 0};
  }
  const uint32_t dropped = carry_devices(old, m);
  for (uint32_t t = 0; t < task_count_; ++t) {
    const uint16_t o = pair_of(m.tasks, t);
    if (o == kNone) continue;
    windows_[t] = old.windows_[o];
    for (uint32_t d = 0; d < device_count_; ++d) {
      const uint16_t od = pair_of(m.devices, d);
      job_count_[t][d] = od == kNone ? 0 : old.job_count_[o][od];
    }
  }
  for (uint32_t r = 0; r < rate_count_; ++r) {
    const uint16_t o = pair_of(m.rates, r);
    if (o != kNone) rate_used_[r] = old.rate_used_[o];
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    const uint16_t o = pair_of(m.invariants, i);
    if (o == kNone) continue;
    state_words_[i] = old.state_words_[o];
    for (uint32_t t = 0; t < task_count_; ++t) {
      const uint16_t ot = pair_of(m.tasks, t);
      if (ot != kNone) task_state_words_[t][i] = old.task_state_words_[ot][o];
    }
  }
  for (uint32_t c = 0; c < command_count_; ++c) {
    const uint16_t o = pair_of(m.commands, c);
    if (o == kNone) continue;
    const uint32_t n = channels(commands_[c]) < channels(old.commands_[o])
                           ? channels(commands_[c])
                           : channels(old.commands_[o]);
    for (uint32_t k = 0; k < n; ++k) last_[last_first_[c] + k] = old.last_[old.last_first_[o] + k];
  }
  return {true, dropped};
}

}  // namespace contego::core::internal
