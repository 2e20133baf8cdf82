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

uint16_t pair_of(const uint16_t* map, uint32_t i) { return map == nullptr ? kNone : map[i]; }

uint32_t channels(const CommandRecord& c) { return c.repeat > 1 ? c.repeat : 1; }

// Whether each of the `count` records `map` pairs has its pair inside the old
// table (`old_count` records) and agreeing with it: agree(id, old id).
template <typename Agree>
bool pairs_agree(const uint16_t* map, uint32_t count, uint32_t old_count, Agree agree) {
  for (uint32_t i = 0; i < count; ++i) {
    const uint16_t o = pair_of(map, i);
    if (o != kNone && (o >= old_count || !agree(i, o))) return false;
  }
  return true;
}

// Calls f(id, old id) for each of the `count` records `map` pairs.
template <typename F>
void each_pair(const uint16_t* map, uint32_t count, F f) {
  for (uint32_t i = 0; i < count; ++i) {
    if (pair_of(map, i) != kNone) f(i, map[i]);
  }
}

}  // namespace

bool CheckerState::carry_pairs_agree(const CheckerState& old, const Checker::CarryMap& m) const {
  auto any = [](uint32_t, uint16_t) { return true; };
  auto same_address = [&](uint32_t d, uint16_t o) {
    const DeviceRecord& a = devices_[d];
    const DeviceRecord& b = old.devices_[o];
    return a.bus == b.bus && a.addr == b.addr && a.ten_bit == b.ten_bit && a.profile == b.profile;
  };
  auto same_command = [&](uint32_t c, uint16_t o) {
    return pair_of(m.devices, commands_[c].device) == old.commands_[o].device &&
           commands_[c].field_count == old.commands_[o].field_count;
  };
  auto same_rate = [&](uint32_t r, uint16_t o) {
    return pair_of(m.tasks, rates_[r].task) == old.rates_[o].task &&
           pair_of(m.devices, rates_[r].device) == old.rates_[o].device;
  };
  auto same_invariant = [&](uint32_t i, uint16_t o) {
    return pair_of(m.devices, invariants_[i].device) == old.invariants_[o].device &&
           invariants_[i].scope == old.invariants_[o].scope;
  };
  return pairs_agree(m.tasks, task_count_, old.task_count_, any) &&
         pairs_agree(m.devices, device_count_, old.device_count_, same_address) &&
         pairs_agree(m.commands, command_count_, old.command_count_, same_command) &&
         pairs_agree(m.rates, rate_count_, old.rate_count_, same_rate) &&
         pairs_agree(m.invariants, invariant_count_, old.invariant_count_, same_invariant);
}

// Shadows, staged writes, violations and the latch of every paired device.
// The image-derived parts (lookup, power-on values) stay this image's.
uint32_t CheckerState::carry_devices(const CheckerState& old, const Checker::CarryMap& m) {
  uint32_t dropped = 0;
  each_pair(m.devices, device_count_, [&](uint32_t d, uint16_t o) {
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
  });
  return dropped;
}

Checker::CarryResult CheckerState::carry_from(const CheckerState& old, const Checker::CarryMap& m) {
  if (!loaded_ || !old.loaded_ || journal_.active || old.journal_.active ||
      !carry_pairs_agree(old, m)) {
    return {false, 0};
  }
  const uint32_t dropped = carry_devices(old, m);
  each_pair(m.tasks, task_count_, [&](uint32_t t, uint16_t o) {
    windows_[t] = old.windows_[o];
    for (uint32_t d = 0; d < device_count_; ++d) {
      const uint16_t od = pair_of(m.devices, d);
      job_count_[t][d] = od == kNone ? 0 : old.job_count_[o][od];
    }
  });
  each_pair(m.rates, rate_count_,
            [&](uint32_t r, uint16_t o) { rate_used_[r] = old.rate_used_[o]; });
  each_pair(m.invariants, invariant_count_, [&](uint32_t i, uint16_t o) {
    state_words_[i] = old.state_words_[o];
    each_pair(m.tasks, task_count_, [&](uint32_t t, uint16_t ot) {
      task_state_words_[t][i] = old.task_state_words_[ot][o];
    });
  });
  each_pair(m.commands, command_count_, [&](uint32_t c, uint16_t o) {
    const uint32_t n = channels(commands_[c]) < channels(old.commands_[o])
                           ? channels(commands_[c])
                           : channels(old.commands_[o]);
    for (uint32_t k = 0; k < n; ++k) last_[last_first_[c] + k] = old.last_[old.last_first_[o] + k];
  });
  return {true, dropped};
}

}  // namespace contego::core::internal
