#include "monitor/monitor.h"

#include <errno.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <fmt/core.h>

#include "monitor/expressible.h"
#include "monitor/retry.h"

namespace contego::monitor {

Monitor::Monitor(Decider& decider, AuditLog& audit, Clock& clock)
    : decider_(&decider), audit_(audit), clock_(clock) {
  core::Host host{};
  host.context = this;
  host.read_sample = &Monitor::host_read_sample;
  host.audit = &Monitor::host_audit;
  decider_->set_host(host);
  readings_.reset(decider_->device_count());
  for (uint16_t d = 0; d < decider_->device_count(); ++d)
    readings_.describe(d, decider_->device(d));
}

Monitor::~Monitor() { stop_sampling(); }

void Monitor::add_bus(uint8_t number, bus::Bus* bus) {
  base::MutexLock lock(mu_);
  buses_[number] = bus;
}

bool Monitor::has_bus(uint8_t bus) {
  base::MutexLock lock(mu_);
  return buses_.count(bus) != 0;
}

uint64_t Monitor::funcs(uint8_t bus) {
  base::MutexLock lock(mu_);
  auto it = buses_.find(bus);
  return it == buses_.end() ? 0 : it->second->funcs();
}

// Called by the core inside check(), with mu_ held: the reading the command
// being checked is judged against (readings/sensor_readings.h).
uint32_t Monitor::host_read_sample(void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                                   uint64_t* taken_at_us) {
  auto* self = static_cast<Monitor*>(ctx);
  self->mu_.assume_held();  // the core calls back from check(), under mu_
  const readings::Reading* r =
      self->readings_.for_check(self->checking_task_, device, self->checking_now_us_);
  if (r == nullptr) return 0;
  const uint32_t n = std::min(capacity, r->len);
  std::copy_n(r->bytes.begin(), n, buf);
  if (taken_at_us != nullptr) *taken_at_us = r->taken_at_us;
  return n;
}

void Monitor::host_audit(void* ctx, const core::AuditRecord* record) {
  auto* self = static_cast<Monitor*>(ctx);
  self->mu_.assume_held();  // the core calls back from check(), under mu_
  // No action without a record: a decision whose line is not in the log
  // is refused by transfer() (checked after each check()).
  RecordNames names = self->names_.of(*record);
  names.complain = self->complain_now_;
  names.ignore_errno =
      record->task < core::kMaxTasks ? self->facts_.ignore_errnos[record->task] : 0;
  names.tx = static_cast<int64_t>(self->check_seq_);
  if (self->readings_json_seq_ != self->check_seq_) self->describe_readings_locked();
  names.readings = &self->readings_json_;
  if (!self->audit_.decision(*record, names)) self->audit_lost_ = true;
  self->drops_.note(*record, names, self->checking_now_us_);
}

// Each sensor's latest sample as a check of the task sees it (its own reads
// included), with its age: what `contego replay` feeds a policy's signals.
void Monitor::describe_readings_locked() {
  readings_json_seq_ = check_seq_;
  readings_json_.clear();
  static constexpr char kHex[] = "0123456789abcdef";
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    if (decider_->device(d).sample_len == 0) continue;
    readings_json_ += readings_json_.empty() ? "{\"" : ",\"";
    readings_json_ += d < names_.devices.size() ? names_.devices[d] : std::to_string(d);
    const readings::Reading* r = readings_.for_check(checking_task_, d, checking_now_us_);
    if (r == nullptr) {
      readings_json_ += "\":null";
      continue;
    }
    const uint64_t age = checking_now_us_ > r->taken_at_us ? checking_now_us_ - r->taken_at_us : 0;
    readings_json_ += fmt::format("\":{{\"age_us\":{},\"bytes\":\"", age);
    for (uint32_t i = 0; i < r->len; ++i) {
      if (i != 0) readings_json_ += ' ';
      readings_json_ += kHex[r->bytes[i] >> 4];
      readings_json_ += kHex[r->bytes[i] & 15];
    }
    readings_json_ += "\"}";
  }
  if (!readings_json_.empty()) readings_json_ += '}';
}

bool Monitor::ComplainScope::any() const {
  return all || devices != 0 || std::find(tasks.begin(), tasks.end(), true) != tasks.end();
}

void Monitor::set_complain(ComplainScope scope) {
  base::MutexLock lock(mu_);
  complain_ = std::move(scope);
}

bool Monitor::complains_task_locked(uint16_t task) const {
  return complain_.all || (task < complain_.tasks.size() && complain_.tasks[task]);
}

bool Monitor::complains_locked(uint16_t task, const gate::Transfer& t) const {
  if (complains_task_locked(task)) return true;
  if (complain_.devices == 0) return false;
  auto complaining = [&](uint16_t addr) REQUIRES(mu_) {
    for (uint16_t d = 0; d < decider_->device_count() && d < 32; ++d) {
      const core::DeviceRecord& rec = decider_->device(d);
      if (rec.bus == t.bus && rec.addr == addr) return ((complain_.devices >> d) & 1u) != 0;
    }
    return false;  // no device of the policy there: enforced
  };
  if (t.quick) return complaining(t.quick_addr);
  if (t.messages.empty()) return false;
  for (const gate::Message& m : t.messages) {
    if (!complaining(m.addr)) return false;
  }
  return true;
}

int Monitor::act_as_sent_locked(const gate::Transfer& t,
                                const std::vector<gate::PlannedTx>& planned) {
  for (size_t i = 0; i < planned.size(); ++i) {
    if (planned[i].kind != core::TxKind::kWrite) continue;
    const std::vector<uint8_t>& bytes = planned[i].bytes;
    if (bytes.size() > core::kMaxEmitBytes) return EINVAL;
    core::Verdict& v = verdicts_[i];
    v.decision = core::Decision::kAllow;
    v.bus = t.bus;
    v.addr = planned[i].addr;
    v.emit_count = 1;
    v.emit_len[0] = static_cast<uint16_t>(bytes.size());
    v.emit_bytes_used = static_cast<uint16_t>(bytes.size());
    std::copy(bytes.begin(), bytes.end(), v.emit_bytes);
  }
  return 0;
}

std::string Monitor::decision_summary(uint16_t task) const {
  base::MutexLock lock(mu_);
  return drops_.summary(task);
}

DecisionCounts Monitor::decision_counts(uint16_t task) const {
  base::MutexLock lock(mu_);
  return drops_.counts(task);
}

void Monitor::set_drop_report(std::FILE* out) {
  base::MutexLock lock(mu_);
  drops_ = DropReport(out);
}

int Monitor::perform_emits(const core::Verdict& v, bool ten_bit, const gate::Timing& timing) {
  auto it = buses_.find(v.bus);
  if (it == buses_.end()) return ENODEV;
  uint32_t offset = 0;
  for (uint32_t i = 0; i < v.emit_count && i < core::kMaxEmits; ++i) {
    const uint16_t len = v.emit_len[i];
    if (offset + len > core::kMaxEmitBytes) return EIO;  // malformed verdict: fail closed
    uint8_t bytes[core::kMaxEmitBytes];  // the bus gets a copy it may not write back into v
    std::copy_n(v.emit_bytes + offset, len, bytes);
    offset += len;
    bus::Msg m{v.addr, static_cast<uint16_t>(ten_bit ? gate::kMsgTen : 0), len, bytes};
    if (int err = try_by(timing, retry_cap_us_, clock_,
                         [&] {
                           return it->second->transfer({&m, 1});
                         });
        err != 0)
      return err;
    readings_.on_write(v.bus, v.addr, {v.emit_bytes + offset - len, len});
  }
  return 0;
}

void Monitor::set_budget_factor(uint32_t factor) { budget_factor_.store(factor); }

void Monitor::set_task_facts(TaskFacts facts) {
  base::MutexLock lock(mu_);
  facts_ = std::move(facts);
}

uint64_t first_release_us(std::optional<uint64_t> phase_us, uint64_t period_us,
                          uint64_t contact_us) {
  return contego_grid_first_release(phase_us.has_value(), phase_us.value_or(0), period_us,
                                    contact_us);
}

Result<bool> Monitor::reset_latch(const std::string& device, uid_t uid) {
  base::MutexLock lock(mu_);
  const auto& names = names_.devices;
  const auto it = std::find(names.begin(), names.end(), device);
  if (it == names.end()) return make_error("the policy has no device '" + device + "'");
  const auto d = static_cast<uint16_t>(it - names.begin());
  const bool was = decider_->latched(d);
  // No action without a record.
  if (!audit_.event("reset", fmt::format("device {} ({}) reset by uid {}; it was {}", d, device,
                                         uid, was ? "latched" : "not latched"))) {
    return make_error("the audit record of the reset could not be written; nothing was reset");
  }
  decider_->reset_latch(d);
  return was;
}

// The over-budget hold bounds the checking a task costs per job (the
// analysis's N·C^o) with two counts, so that one kind of transfer never
// spends the other's budget:
// - transfers that acted (a write allowed or substituted) get `factor` x N
//   per job; past it, the next transfer waits *before* it is checked for the
//   task's next release, and is charged to that job;
// - transfers that did not act (ignored, refused, or register writes only
//   staged) get `factor` x max(N, kNonActingFloor) per job; past it, the
//   thread that sent one waits *after* its answer for the next release.
// A flood of dropped commands so holds the thread that floods, never the
// task's own acting commands, and a vendor library's start-up writes that a
// policy ignores by design (the PCA9685 constructor: 13) do not wait.
void Monitor::hold_if_over_budget(uint16_t task) {
  const uint32_t factor = budget_factor_.load(std::memory_order_relaxed);
  if (factor == 0) return;
  uint64_t hold_until = 0;
  {
    base::MutexLock lock(mu_);
    if (complains_task_locked(task)) return;  // observed as it runs, never held
    const uint64_t period = decider_->task_period_us(task);
    const uint64_t budget = uint64_t{factor} * decider_->task_actuations_per_job(task);
    if (period == 0 || budget == 0) return;
    const uint64_t now = clock_.now_us();
    const uint32_t job = job_at_locked(task, now);
    Budget& b = budgets_[task];
    const uint32_t charged = contego_budget_before(&b.counts, job, period, budget);
    if (charged == job) return;
    hold_until = next_release_locked(task, charged - 1);
    report_hold_locked(task, b, now, budget, "acting transfers");
  }
  clock_.sleep_until_us(hold_until);
}

void Monitor::report_hold_locked(uint16_t task, Budget& b, uint64_t now, uint64_t budget,
                                 const char* what) {
  ++b.holds_unreported;
  holds_.fetch_add(1);
  const char* name = task < names_.tasks.size() ? names_.tasks[task].c_str() : "";
  if (b.reported_at_us == 0 || now - b.reported_at_us >= 1000000) {
    audit_.event("over-budget",
                 fmt::format("task {} ({}): over its budget of {} {} per job; {} "
                             "transfer(s) held to the end of the period since the last report",
                             task, name, budget, what, b.holds_unreported));
    b.holds_unreported = 0;
    b.reported_at_us = now;
  }
  if (!b.told) {
    // Once per task, where the user sees it (the supervised program's terminal
    // under `contego run`): a held program otherwise looks hung.
    b.told = true;
    fmt::print(stderr,
               "contego: task {}: more than {} {} in one job (its budget: --budget-factor x "
               "actuations); the thread sending more waits for the next period\n",
               name, budget, what);
  }
}

// After a transfer was decided, under the decision's own lock (no second
// lock on the check path): counts it as acting or not. A non-acting one past
// its budget returns when the sending thread may go on (the task's next
// release); 0: at once.
uint64_t Monitor::charge_transfer_locked(uint16_t task, bool acted) {
  const uint32_t factor = budget_factor_.load(std::memory_order_relaxed);
  if (factor == 0) return 0;
  const uint64_t period = decider_->task_period_us(task);
  const uint64_t actuations = decider_->task_actuations_per_job(task);
  if (period == 0 || actuations == 0 || complains_task_locked(task)) return 0;
  const uint64_t now = clock_.now_us();
  const uint32_t job = job_at_locked(task, now);
  Budget& b = budgets_[task];
  const uint64_t budget = uint64_t{factor} * std::max<uint64_t>(actuations, kNonActingFloor);
  if (!contego_budget_after(&b.counts, job, period, acted ? 1 : 0, budget)) return 0;
  report_hold_locked(task, b, now, budget, "transfers that did not act");
  return next_release_locked(task, job);
}

gate::TransferReply Monitor::transfer(uint16_t task, const gate::Transfer& t) {
  if (Status st = gate::validate(t); !st.ok()) {
    audit_.event("malformed", fmt::format("task {}: {}", task, st.error()));
    gate::TransferReply reply;
    reply.err = EINVAL;
    return reply;
  }
  // Probes (reads, register reads, SMBus quick: address scans) actuate
  // nothing, so they do not spend the task's actuation budget.
  const bool probe = gate::is_probe(t);
  if (!probe) hold_if_over_budget(task);
  uint64_t hold_until = 0;
  gate::TransferReply reply;
  {
    base::MutexLock lock(mu_);
    bool acted = false;
    reply = decide_and_act_locked(task, t, &acted);
    complain_now_ = false;  // records written outside a transfer (safe states) are enforced
    if (!probe) hold_until = charge_transfer_locked(task, acted);
  }
  if (hold_until != 0) clock_.sleep_until_us(hold_until);
  return reply;
}

gate::TransferReply Monitor::decide_and_act_locked(uint16_t task, const gate::Transfer& t,
                                                   bool* acted) {
  gate::TransferReply reply;
  auto bus_it = buses_.find(t.bus);
  if (bus_it == buses_.end()) {
    reply.err = ENODEV;
    return reply;
  }
  bus::Bus& bus = *bus_it->second;
  gate::to_transactions(t, planned_);
  const std::vector<gate::PlannedTx>& planned = planned_;
  // What this adapter cannot put on the wire (an SMBus-only one) is refused
  // before the core decides: no rate window spent, no decision logged.
  if (Status st = inexpressible(bus, t, planned); !st.ok()) {
    audit_.event("inexpressible", fmt::format("task {}: bus {}: {}", task, t.bus, st.error()));
    reply.err = EOPNOTSUPP;
    return reply;
  }

  // Decide every transaction first, as one transfer in the core: nothing of
  // the call acts unless the core's combination of the verdicts says so, and
  // then the core's model holds exactly what acts (docs/core.md, "Transfers").
  size_t checked = 0;
  const uint64_t check_started_ns = monotonic_ns();
  const int check_err = check_transfer(task, t, planned, &checked);
  check_cost_.add(monotonic_ns() - check_started_ns);
  if (check_err != 0) {
    reply.err = check_err;
    return reply;
  }
  const core::TransferVerdict tv =
      core::combine_transfer(verdicts_.data(), static_cast<uint32_t>(checked));
  if (tv.action == core::TransferAction::kPerform ||
      tv.action == core::TransferAction::kSubstitute) {
    // What the verdicts send (a substitute, the core's register-by-register
    // writes) is checked the same way before any part of the call acts:
    // otherwise an earlier part could act before a later one fails at the
    // bus. The shared model's rule, contego.ko's too.
    if (Status st = inexpressible(bus, t, planned, &verdicts_); !st.ok()) {
      decider_->abort_transfer(core::Decision::kReject);
      audit_.event("inexpressible", fmt::format("task {}: bus {}: {}", task, t.bus, st.error()));
      reply.err = EOPNOTSUPP;
      return reply;
    }
    decider_->commit_transfer();
    // It acted if a write of it reached a device (not only staged).
    for (size_t i = 0; i < planned.size() && i < checked; ++i) {
      const core::Verdict& v = verdicts_[i];
      if (planned[i].kind != core::TxKind::kRead && v.reason != core::Reason::kStaged &&
          (v.decision == core::Decision::kAllow || v.decision == core::Decision::kFailsafe)) {
        *acted = true;
      }
    }
    return perform_transfer(task, t, planned);
  }
  audit_lost_ = false;
  decider_->abort_transfer(core::transfer_decision(tv.action));
  if (audit_lost_) {
    audit_refusals_.fetch_add(1);
    drive_safe_state_locked("an audit record could not be written: failing closed");
    reply.err = EIO;
    return reply;
  }
  if (complain_now_) {
    // Complain mode: recorded as the policy would decide, acted as sent. The
    // model was undone as for a drop, so it stays the one enforce mode keeps.
    if (int err = act_as_sent_locked(t, planned); err != 0) {
      reply.err = err;
      return reply;
    }
    for (const gate::PlannedTx& p : planned) *acted = *acted || p.kind == core::TxKind::kWrite;
    return perform_transfer(task, t, planned);
  }
  if (tv.action == core::TransferAction::kRefuse) {
    const uint8_t err = verdicts_[tv.decider].reply_errno;
    reply.err = err != 0 ? err : EPERM;
    return reply;
  }
  if (tv.action == core::TransferAction::kSafeState) drive_transfer_safe_states(task, checked);
  // The policy's `ignore_errno`: the call fails, and nothing of it acted either way.
  if (tv.action == core::TransferAction::kIgnore && task < core::kMaxTasks) {
    reply.err = facts_.ignore_errnos[task];
    if (reply.err != 0) return reply;
  }
  // Ignored (or replaced by safe states): the call succeeds and nothing of it
  // acted; its reads read nothing.
  for (const gate::PlannedTx& p : planned) {
    if (p.kind != core::TxKind::kRead) continue;
    reply.reads.emplace_back(t.messages[p.first_message + p.message_count - 1].len, 0);
  }
  return reply;
}

// Checks each transaction of `planned` inside one core transfer, stopping at
// the first reject (what follows cannot change the outcome). Returns 0, or
// EIO when a decision's audit record could not be written (the transfer is
// aborted and the safe state driven).
int Monitor::check_transfer(uint16_t task, const gate::Transfer& t,
                            const std::vector<gate::PlannedTx>& planned, size_t* checked) {
  const uint64_t now = clock_.now_us();
  const uint32_t job = job_at_locked(task, now);
  checking_task_ = task;
  checking_now_us_ = now;
  complain_now_ = complain_.any() && complains_locked(task, t);
  verdicts_.resize(planned.size());
  decider_->begin_transfer();
  for (size_t i = 0; i < planned.size(); ++i) {
    const gate::PlannedTx& p = planned[i];
    core::Transaction tx{};
    tx.task = task;
    tx.bus = t.bus;
    tx.kind = p.kind;
    tx.addr = p.addr;
    tx.ten_bit = p.ten_bit ? 1 : 0;
    tx.job = job;
    tx.len = static_cast<uint32_t>(p.bytes.size());
    tx.bytes = p.bytes.data();
    tx.now_us = now;
    core::Verdict& v = verdicts_[i];
    // Every field before the emit arrays (those are read only up to
    // emit_count and emit_bytes_used, now 0): clearing 400 bytes per check
    // cost more than the rest of this loop.
    std::memset(&v, 0, offsetof(core::Verdict, emit_len));
    v.decision = core::Decision::kReject;  // fail closed if the decider leaves it untouched
    v.reply_errno = EPERM;
    audit_lost_ = false;
    ++check_seq_;
    decider_->check(tx, &v);
    decisions_.fetch_add(1);
    *checked = i + 1;
    if (audit_lost_) {
      // The record of this decision could not be written: it does not act,
      // nothing of the call does, and the actuators go to their safe state
      // (best effort: the records of that may fail too).
      decider_->abort_transfer(core::Decision::kReject);
      audit_refusals_.fetch_add(1);
      drive_safe_state_locked("an audit record could not be written: failing closed");
      return EIO;
    }
    if (v.decision == core::Decision::kReject) break;
  }
  return 0;
}

// A fail-safe verdict inside a transfer of several messages: the substitute
// was computed on a model that included the other messages, which do not
// act, so the device's declared safe state is written instead.
void Monitor::drive_transfer_safe_states(uint16_t task, size_t checked) {
  uint32_t driven = 0;  // device bits (kMaxDevices <= 32)
  for (size_t i = 0; i < checked; ++i) {
    const core::Verdict& v = verdicts_[i];
    if (v.decision != core::Decision::kFailsafe || v.device >= decider_->device_count() ||
        ((driven >> v.device) & 1u) != 0) {
      continue;
    }
    driven |= 1u << v.device;
    const core::DeviceRecord& rec = decider_->device(v.device);
    audit_.event("safe-state", fmt::format("task {}: a message of a combined transfer failed "
                                           "safe; device {} driven to its safe state instead",
                                           task, v.device));
    core::Verdict safe{};
    if (!decider_->safe_state(v.device, &safe)) continue;
    if (int err = perform_emits(safe, rec.ten_bit != 0); err != 0) {
      audit_.event("fault", fmt::format("safe state of device {} failed: errno {}", v.device, err));
    }
  }
}

// Performs, in message order, only what the core allowed or substituted.
gate::TransferReply Monitor::perform_transfer(uint16_t task, const gate::Transfer& t,
                                              const std::vector<gate::PlannedTx>& planned) {
  gate::TransferReply reply;
  bus::Bus& bus = *buses_.at(t.bus);
  retry_cap_us_ = t.timing.own ? decider_->task_period_us(task) : 0;  // used only then
  // One transaction with one emit goes out the same either way: the loop
  // below sends it without copying the call (the common write).
  if ((planned.size() > 1 || verdicts_[0].emit_count > 1) && acts_as_sent(planned, verdicts_) &&
      perform_as_sent(task, t, planned, reply)) {
    return reply;
  }
  for (size_t i = 0; i < planned.size(); ++i) {
    const gate::PlannedTx& p = planned[i];
    const core::Verdict& v = verdicts_[i];
    bus::Msg emit;
    if (p.kind == core::TxKind::kQuick) {
      reply.err =
          try_by(t.timing, retry_cap_us_, clock_, [&] { return bus.quick(p.addr, t.quick_read); });
    } else if (p.kind == core::TxKind::kWrite && i + 1 < planned.size() &&
               planned[i + 1].answers_write &&
               emit_goes_with_read(bus, v, read_message(t, planned[i + 1]), &emit)) {
      // The write and the read answering it, together as the program sent
      // them (a repeated start, no stop between).
      reply.err = perform_read(task, t, planned[++i], &emit, reply);
      if (reply.err == 0) readings_.on_write(v.bus, v.addr, {v.emit_bytes, v.emit_len[0]});
    } else if (p.kind == core::TxKind::kWrite) {
      reply.err = perform_emits(v, p.ten_bit, t.timing);
    } else {
      reply.err = perform_read(task, t, p, nullptr, reply);
    }
    if (reply.err != 0) {
      audit_.event("bus-error",
                   fmt::format("bus {} addr 0x{:02x}: errno {}", t.bus, p.addr, reply.err));
      reply.reads.clear();
      return reply;
    }
  }
  return reply;
}

// A call whose every write goes out as sent (acts_as_sent), as the program's
// one combined transfer: its messages in order, no stop between them. False,
// nothing sent, when the adapter has no form for it whole (then each
// transaction goes in its own form).
bool Monitor::perform_as_sent(uint16_t task, const gate::Transfer& t,
                              const std::vector<gate::PlannedTx>& planned,
                              gate::TransferReply& reply) {
  bus::Bus& bus = *buses_.at(t.bus);
  const size_t n = t.messages.size();
  std::vector<std::vector<uint8_t>> bufs(n);  // our copies: writes' bytes, reads' answers
  std::vector<bus::Msg> msgs(n);
  for (size_t k = 0; k < n; ++k) {
    const gate::Message& m = t.messages[k];
    bufs[k] = m.is_read() ? std::vector<uint8_t>(m.len, 0) : m.data;
    msgs[k] = {m.addr, m.flags, m.len, bufs[k].data()};
  }
  if (!bus.expressible(msgs).ok()) return false;
  reply.err = try_by(t.timing, retry_cap_us_, clock_, [&] { return bus.transfer(msgs); });
  if (reply.err != 0) {
    audit_.event("bus-error", fmt::format("bus {} addr 0x{:02x}: errno {}", t.bus,
                                          t.messages[0].addr, reply.err));
    return true;
  }
  for (const gate::PlannedTx& p : planned) {
    const size_t last = p.first_message + p.message_count - 1;
    if (p.kind == core::TxKind::kWrite) {
      readings_.on_write(t.bus, p.addr, p.bytes);
      continue;
    }
    bufs[last].resize(msgs[last].len);
    readings_.on_read(task, t.bus, t.messages[last].addr, p.bytes, bufs[last], clock_.now_us());
    reply.reads.push_back(std::move(bufs[last]));
  }
  return true;
}

// One read of `t`, after its register pointer (our copy) when it has one,
// or after `write` (the emit it answers); its bytes appended to reply.reads.
int Monitor::perform_read(uint16_t task, const gate::Transfer& t, const gate::PlannedTx& p,
                          const bus::Msg* write, gate::TransferReply& reply) {
  bus::Bus& bus = *buses_.at(t.bus);
  const gate::Message& rm = t.messages[p.first_message + p.message_count - 1];
  std::vector<uint8_t> out(rm.len, 0);
  std::vector<uint8_t> pointer = p.bytes;
  uint8_t written[core::kMaxEmitBytes];  // the bus gets a copy it may not write back into
  bus::Msg msgs[2];
  size_t n = 0;
  if (write != nullptr) {
    std::copy_n(write->buf, write->len, written);
    msgs[n++] = {write->addr, write->flags, write->len, written};
  } else if (!pointer.empty()) {
    msgs[n++] = {p.addr, static_cast<uint16_t>(p.ten_bit ? gate::kMsgTen : 0),
                 static_cast<uint16_t>(pointer.size()), pointer.data()};
  }
  msgs[n++] = {rm.addr, rm.flags, rm.len, out.data()};
  const int err = try_by(t.timing, retry_cap_us_, clock_, [&] { return bus.transfer({msgs, n}); });
  out.resize(msgs[n - 1].len);
  if (err == 0) readings_.on_read(task, t.bus, rm.addr, p.bytes, out, clock_.now_us());
  reply.reads.push_back(std::move(out));
  return err;
}

void Monitor::job_boundary(uint16_t task) {
  base::MutexLock lock(mu_);
  (void)job_at_locked(task, clock_.now_us());  // at most sets the phase
}

uint32_t Monitor::job_at_locked(uint16_t task, uint64_t now_us) {
  const uint64_t period = decider_->task_period_us(task);
  if (period == 0) return 0;  // no declared task: the core's own windows
  auto it = job_phase_us_.find(task);
  if (it == job_phase_us_.end()) {
    auto d = facts_.phases.find(task);
    const std::optional<uint64_t> declared =
        d == facts_.phases.end() ? std::nullopt : std::optional<uint64_t>(d->second);
    it = job_phase_us_.emplace(task, first_release_us(declared, period, now_us)).first;
  }
  return contego_grid_job(it->second, period, now_us);
}

uint64_t Monitor::next_release_locked(uint16_t task, uint32_t job) const {
  const uint64_t period = decider_->task_period_us(task);
  auto it = job_phase_us_.find(task);
  if (period == 0 || it == job_phase_us_.end()) return 0;
  return it->second + uint64_t{job} * period;
}

uint16_t Monitor::task_priority(uint16_t task) const {
  base::MutexLock lock(mu_);
  return decider_->task_priority(task);
}

uint32_t Monitor::job(uint16_t task) const {
  base::MutexLock lock(mu_);
  auto it = job_phase_us_.find(task);
  const uint64_t period = decider_->task_period_us(task);
  if (it == job_phase_us_.end() || period == 0) return 0;
  return contego_grid_job(it->second, period, clock_.now_us());
}

void Monitor::task_ended(uint16_t task, const std::string& how) {
  base::MutexLock lock(mu_);
  // Only the actuators this task may command: the end of one task's session
  // must not override what the others are doing.
  const uint32_t devices = task < task_devices_.size() ? task_devices_[task] : UINT32_MAX;
  const char* name = task < names_.tasks.size() ? names_.tasks[task].c_str() : "?";
  drive_safe_state_locked(fmt::format("task {} ({}) {}", task, name, how), devices);
  // Its session-scoped state (a sequence's position) ends with it: the next
  // run of the task starts its sequences at their first value.
  if (const uint32_t dropped = decider_->end_session(task); dropped != 0) {
    // Never silent: writes the program was told succeeded that never
    // reached the device (a register group whose last register never came).
    const std::string what = fmt::format(
        "task {} ({}) exited with {} register write(s) staged and never completed (their "
        "group's last register never came): they never reached the device",
        task, name, dropped);
    audit_.event("staged-dropped", what);
    if (std::FILE* out = drops_.out(); out != nullptr) {
      fmt::print(out, "contego: {}\n", what);
      (void)std::fflush(out);
    }
  }
  // The job grid stays: a program that reconnects or restarts under the same
  // task joins it, so leaving cannot open a fresh job (and budget).
  readings_.forget_task(task);
}

std::vector<DeviceFailure> Monitor::drive_safe_state(const std::string& why) {
  base::MutexLock lock(mu_);
  return drive_safe_state_locked(why);
}

std::vector<DeviceFailure> Monitor::drive_safe_state_locked(const std::string& why,
                                                            uint32_t devices) {
  audit_.event("safe-state", why);
  checking_task_ = core::kNoTask;  // a computed safe state reads the newest readings
  checking_now_us_ = clock_.now_us();
  std::vector<DeviceFailure> failed;
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    if (d < 32 && (devices & (1u << d)) == 0) continue;
    const core::DeviceRecord& rec = decider_->device(d);
    if ((rec.role & core::kRoleActuator) == 0) continue;
    core::Verdict v{};
    if (!decider_->safe_state(d, &v)) continue;
    if (int err = perform_emits(v, rec.ten_bit != 0); err != 0) {
      auto it = buses_.find(v.bus);
      const std::string cause =
          it == buses_.end() ? "" : emits_inexpressible(*it->second, v, rec.ten_bit).error();
      audit_.event("fault",
                   fmt::format("safe state of device {} (i2c-{} 0x{:02x}) failed: errno {}{}{}", d,
                               rec.bus, rec.addr, err, cause.empty() ? "" : ": ", cause));
      failed.push_back({d, err});
    } else {
      safe_at_us_[d] = checking_now_us_;
    }
  }
  return failed;
}

int Monitor::sample_device_locked(uint16_t d) {
  const core::DeviceRecord& rec = decider_->device(d);
  if (rec.sample_len == 0 || rec.sample_len > core::kMaxSampleBytes) return 0;
  auto it = buses_.find(rec.bus);
  if (it == buses_.end()) return ENODEV;
  std::array<uint8_t, core::kMaxSampleBytes> sample{};
  std::array<uint8_t, 8> request{};
  const uint8_t req_len = std::min<uint8_t>(rec.sample_request_len, 8);
  std::copy_n(rec.sample_request, req_len, request.begin());
  const uint16_t ten = rec.ten_bit ? gate::kMsgTen : 0;
  // An adapter without plain I2C reads a register only in one transaction
  // (register byte, repeated start, read), so the two messages go together.
  const bool combined = req_len == 1 && !(it->second->funcs() & bus::kFuncI2c);
  bus::Msg w{rec.addr, ten, req_len, request.data()};
  if (req_len > 0 && !combined) {
    if (int err = it->second->transfer({&w, 1}); err != 0) {
      readings_.on_sample_failed(d);  // the signal is unavailable (fail closed)
      return err;
    }
  }
  bus::Msg rw[2] = {
      w, {rec.addr, static_cast<uint16_t>(ten | gate::kMsgRead), rec.sample_len, sample.data()}};
  if (int err =
          it->second->transfer(combined ? std::span<bus::Msg>(rw) : std::span<bus::Msg>(rw + 1, 1));
      err != 0) {
    readings_.on_sample_failed(d);
    return err;
  }
  readings_.on_sample(d, {sample.data(), rw[1].len}, clock_.now_us());
  return 0;
}

std::vector<DeviceFailure> Monitor::sample_all() {
  base::MutexLock lock(mu_);
  std::vector<DeviceFailure> failed;
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    if ((decider_->device(d).role & core::kRoleSensor) == 0) continue;
    if (int err = sample_device_locked(d); err != 0) failed.push_back({d, err});
  }
  return failed;
}

uint64_t Monitor::sample_due() {
  base::MutexLock lock(mu_);
  return sample_due_locked();
}

uint64_t Monitor::sample_due_locked() {
  const uint64_t now = clock_.now_us();
  uint64_t next = now + 100000;
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    const core::DeviceRecord& rec = decider_->device(d);
    if (!(rec.role & core::kRoleSensor) || rec.sample_period_us == 0) continue;
    uint64_t& at = sample_due_us_[d];
    if (at <= now) {
      sample_device_locked(d);
      at = now + rec.sample_period_us;
    }
    next = std::min(next, at);
  }
  return next;
}

void Monitor::start_sampling() {
  base::MutexLock lock(mu_);
  if (sampler_.joinable()) return;
  // No sensor with a sample period: a thread would only wake to find
  // nothing due (every 100 ms, for the life of the monitor).
  bool periodic = false;
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    const core::DeviceRecord& rec = decider_->device(d);
    periodic = periodic || ((rec.role & core::kRoleSensor) && rec.sample_period_us != 0);
  }
  if (!periodic) return;
  sampler_stop_ = false;
  sampler_ = std::thread([this] {
    base::MutexLock held(mu_);
    while (!sampler_stop_) {
      const uint64_t next = sample_due_locked();
      held.wait_for(sampler_cv_, std::chrono::microseconds(next - std::min(next, clock_.now_us())),
                    [this]() REQUIRES(mu_) { return sampler_stop_; });
    }
  });
}

void Monitor::stop_sampling() {
  {
    base::MutexLock lock(mu_);
    sampler_stop_ = true;
  }
  sampler_cv_.notify_all();
  if (sampler_.joinable()) sampler_.join();
}

}  // namespace contego::monitor
