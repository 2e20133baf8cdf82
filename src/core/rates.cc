// Rate windows and counts (INV^RC): a task's job window, which rate rules
// select a command, and what they count (the commands that act).
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {

void CheckerState::index_rules() {
  for (uint32_t r = 0; r < rate_count_; ++r) {
    const RateRecord& rr = rates_[r];
    if (rr.task >= kMaxTasks || rr.device >= kMaxDevices) continue;  // selects nothing
    rates_of_[rr.task][rr.device] |= uint64_t{1} << r;
    task_rates_[rr.task] |= uint64_t{1} << r;
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    for (uint32_t c = 0; c < command_count_; ++c) {  // the verifier keeps them the device's
      if (mask_has(invariants_[i].commands, c)) invariants_of_[c][i / 64] |= uint64_t{1} << i % 64;
    }
  }
}

void CheckerState::update_window(const Transaction& tx) {
  const uint32_t period = tasks_[tx.task].period_us;
  TaskWindow& w = windows_[tx.task];
  uint64_t key = 0;
  if (tx.job != 0) {
    key = (uint64_t{1} << 63) | tx.job;
    w.timed = false;
  } else if (period != 0) {
    // Inside the time window of the last check: no 64-bit division.
    if (w.valid && w.timed && tx.now_us >= w.start_us && tx.now_us - w.start_us < period) return;
    key = tx.now_us / period;
    w.timed = true;
    w.start_us = key * period;
  } else {
    w.timed = false;
  }
  if (w.valid && w.key == key) return;
  w.valid = true;
  w.key = key;
  __builtin_memset(job_count_[tx.task], 0, sizeof(job_count_[tx.task]));
  for (uint64_t bits = task_rates_[tx.task]; bits != 0; bits &= bits - 1) {
    rate_used_[__builtin_ctzll(bits)] = 0;
  }
}

bool CheckerState::selects(const RateRecord& rr, const Transaction& tx, const Decoded& d) const {
  return rr.task == tx.task && rr.device == d.device && mask_has(rr.commands, d.command) &&
         (rr.only_channel == 0 || d.index == rr.only_channel - 1);
}

bool CheckerState::rate_decides(const Transaction& tx, const Decoded& d) const {
  for (uint64_t bits = rates_of_[tx.task][d.device]; bits != 0; bits &= bits - 1) {
    const uint32_t r = static_cast<uint32_t>(__builtin_ctzll(bits));
    if (selects(rates_[r], tx, d) && rate_used_[r] >= rates_[r].max_per_job) return true;
  }
  return false;
}

uint16_t CheckerState::refusing_rate(const Transaction& tx, const Decoded& d) const {
  if (tx.task >= kMaxTasks || d.device >= kMaxDevices) return kNone;
  for (uint64_t bits = rates_of_[tx.task][d.device]; bits != 0; bits &= bits - 1) {
    const uint32_t r = static_cast<uint32_t>(__builtin_ctzll(bits));
    const RateRecord& rr = rates_[r];
    if (selects(rr, tx, d) && rr.response == Response::kReject && rate_used_[r] >= rr.max_per_job) {
      return static_cast<uint16_t>(r);
    }
  }
  return kNone;
}

// A rate counts the commands that act (allowed or substituted) in the policy's
// unit: one decoded command, whatever number of bus writes carried it. A
// dropped or refused command spends nothing, so a flood of them cannot take
// the slots of the task's own commands (docs/policy-language.md, "What a rate
// counts").
void CheckerState::count_acting(const Transaction& tx, const Outcome& o, uint64_t rates_hit) {
  if ((o.decision != Decision::kAllow && o.decision != Decision::kFailsafe) ||
      tx.task >= kMaxTasks) {
    return;
  }
  uint32_t& jc = job_count_[tx.task][o.device];
  if (jc != 0xFFFFFFFFu) ++jc;
  for (uint64_t bits = rates_hit; bits != 0; bits &= bits - 1) {
    uint32_t& used = rate_used_[__builtin_ctzll(bits)];
    if (used != 0xFFFFFFFFu) ++used;
  }
}

}  // namespace contego::core::internal
