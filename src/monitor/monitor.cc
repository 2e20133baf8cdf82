#include "monitor/monitor.h"

#include <errno.h>
#include <time.h>

#include <algorithm>
#include <fmt/core.h>

#include "monitor/expressible.h"

namespace contego::monitor {

uint64_t monotonic_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
}

Monitor::Monitor(Decider& decider, AuditLog& audit) : decider_(decider), audit_(audit) {
  core::Host host{};
  host.context = this;
  host.read_sample = &Monitor::host_read_sample;
  host.audit = &Monitor::host_audit;
  decider_.set_host(host);
}

Monitor::~Monitor() { stop_sampling(); }

void Monitor::add_bus(uint8_t number, bus::Bus* bus) {
  std::lock_guard lock(mu_);
  buses_[number] = bus;
}

bool Monitor::has_bus(uint8_t bus) {
  std::lock_guard lock(mu_);
  return buses_.count(bus) != 0;
}

uint64_t Monitor::funcs(uint8_t bus) {
  std::lock_guard lock(mu_);
  auto it = buses_.find(bus);
  return it == buses_.end() ? 0 : it->second->funcs();
}

// Called by the core inside check(), with mu_ held.
uint32_t Monitor::host_read_sample(void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                                   uint64_t* taken_at_us) {
  auto* self = static_cast<Monitor*>(ctx);
  auto it = self->samples_.find(device);
  if (it == self->samples_.end() || it->second.len == 0) return 0;
  const uint32_t n = std::min(capacity, it->second.len);
  std::copy_n(it->second.bytes.begin(), n, buf);
  if (taken_at_us != nullptr) *taken_at_us = it->second.taken_at_us;
  return n;
}

void Monitor::host_audit(void* ctx, const core::AuditRecord* record) {
  auto* self = static_cast<Monitor*>(ctx);
  const char* name =
      record->task < self->task_names_.size() ? self->task_names_[record->task].c_str() : nullptr;
  // No action without a record: a decision whose line is not in the log
  // is refused by transfer() (checked after each check()).
  if (!self->audit_.decision(*record, name)) self->audit_lost_ = true;
}

int Monitor::perform_emits(const core::Verdict& v, bool ten_bit) {
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
    if (int err = it->second->transfer({&m, 1}); err != 0) return err;
  }
  return 0;
}

void Monitor::set_budget_factor(uint32_t factor) { budget_factor_.store(factor); }

void Monitor::hold_if_over_budget(uint16_t task) {
  const uint32_t factor = budget_factor_.load(std::memory_order_relaxed);
  if (factor == 0) return;
  uint64_t hold_until = 0;
  {
    std::lock_guard lock(mu_);
    const uint64_t period = decider_.task_period_us(task);
    const uint64_t budget = uint64_t{factor} * decider_.task_actuations_per_job(task);
    if (period == 0 || budget == 0) return;
    const uint64_t now = monotonic_us();
    auto job_it = jobs_.find(task);
    const uint32_t job = job_it == jobs_.end() ? 0 : job_it->second.job;
    Budget& b = budgets_[task];
    // A new job (the task slept) or a whole period since the window opened
    // (a task that never sleeps) starts a fresh budget.
    if (b.job != job || now >= b.window_start_us + period) {
      b.job = job;
      b.window_start_us = now;
      b.used = 0;
    }
    if (++b.used <= budget) return;
    hold_until = b.window_start_us + period;
    ++b.holds_unreported;
    holds_.fetch_add(1);
    if (b.reported_at_us == 0 || now - b.reported_at_us >= 1000000) {
      const char* name = task < task_names_.size() ? task_names_[task].c_str() : "";
      audit_.event("over-budget",
                   fmt::format("task {} ({}): over its budget of {} transfers per job; {} "
                               "transfer(s) held to the end of the period since the last report",
                               task, name, budget, b.holds_unreported));
      b.holds_unreported = 0;
      b.reported_at_us = now;
    }
    // The held transfer opens the next window (another thread of the task
    // arriving meanwhile spends that window's budget early, then waits for
    // the one after: on average still `budget` per period).
    b.window_start_us = hold_until;
    b.used = 1;
  }
  const timespec until{static_cast<time_t>(hold_until / 1000000u),
                       static_cast<long>(hold_until % 1000000u) * 1000};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
  }
}

gate::TransferReply Monitor::transfer(uint16_t task, const gate::Transfer& t) {
  gate::TransferReply reply;
  if (std::string why = gate::validate(t); !why.empty()) {
    audit_.event("malformed", fmt::format("task {}: {}", task, why));
    reply.err = EINVAL;
    return reply;
  }
  hold_if_over_budget(task);
  std::lock_guard lock(mu_);
  auto bus_it = buses_.find(t.bus);
  if (bus_it == buses_.end()) {
    reply.err = ENODEV;
    return reply;
  }
  bus::Bus& bus = *bus_it->second;
  const std::vector<gate::PlannedTx> planned = gate::to_transactions(t);
  // What this adapter cannot put on the wire (an SMBus-only one) is refused
  // before the core decides: no rate window spent, no decision logged.
  if (std::string why = inexpressible(bus, t, planned); !why.empty()) {
    audit_.event("inexpressible", fmt::format("task {}: bus {}: {}", task, t.bus, why));
    reply.err = EOPNOTSUPP;
    return reply;
  }

  // Decide every transaction first: one refusal fails the whole call and
  // nothing of it reaches the bus (a write cannot slip through inside a
  // combined transfer that is partly refused).
  const uint64_t now = monotonic_us();
  auto job_it = jobs_.find(task);
  const uint32_t job = job_it == jobs_.end() ? 0 : job_it->second.job;
  std::vector<core::Verdict>& verdicts = verdicts_;
  verdicts.resize(planned.size());
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
    core::Verdict& v = verdicts[i];
    v = core::Verdict{};
    v.decision = core::Decision::kReject;  // fail closed if the decider leaves it untouched
    v.reply_errno = EPERM;
    audit_lost_ = false;
    decider_.check(tx, &v);
    decisions_.fetch_add(1);
    if (audit_lost_) {
      // The record of this decision could not be written: it does not act,
      // nothing of the call does, and the actuators go to their safe state
      // (best effort: the records of that may fail too).
      audit_refusals_.fetch_add(1);
      drive_safe_state_locked("an audit record could not be written: failing closed");
      reply.err = EIO;
      return reply;
    }
    if (v.decision == core::Decision::kReject) {
      reply.err = v.reply_errno != 0 ? v.reply_errno : EPERM;
      return reply;
    }
    if (v.decision != core::Decision::kAllow && v.decision != core::Decision::kIgnore &&
        v.decision != core::Decision::kFailsafe) {
      reply.err = EPERM;
      return reply;
    }
  }

  // A substitute is checked the same way before any part of the call acts.
  for (size_t i = 0; i < planned.size(); ++i) {
    if (planned[i].kind != core::TxKind::kWrite || verdicts[i].decision == core::Decision::kIgnore)
      continue;
    if (std::string why = emits_inexpressible(bus, verdicts[i], planned[i].ten_bit); !why.empty()) {
      audit_.event("inexpressible", fmt::format("task {}: bus {}: {}", task, t.bus, why));
      reply.err = EOPNOTSUPP;
      return reply;
    }
  }

  // Perform, in message order, only what the core allowed or substituted.
  for (size_t i = 0; i < planned.size(); ++i) {
    const gate::PlannedTx& p = planned[i];
    const core::Verdict& v = verdicts[i];
    if (p.kind == core::TxKind::kQuick) {
      if (v.decision == core::Decision::kAllow) reply.err = bus.quick(p.addr, t.quick_read);
    } else if (p.kind == core::TxKind::kWrite) {
      if (v.decision != core::Decision::kIgnore) reply.err = perform_emits(v, p.ten_bit);
    } else {  // a read, with its pointer bytes (our copy) when it has them
      const gate::Message& rm = t.messages[p.first_message + p.message_count - 1];
      std::vector<uint8_t> out(rm.len, 0);
      if (v.decision == core::Decision::kAllow) {
        std::vector<uint8_t> pointer = p.bytes;
        std::vector<bus::Msg> msgs;
        if (!pointer.empty()) {
          msgs.push_back({p.addr, static_cast<uint16_t>(p.ten_bit ? gate::kMsgTen : 0),
                          static_cast<uint16_t>(pointer.size()), pointer.data()});
        }
        msgs.push_back({rm.addr, rm.flags, rm.len, out.data()});
        reply.err = bus.transfer(msgs);
        out.resize(msgs.back().len);
      }
      reply.reads.push_back(std::move(out));
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

void Monitor::job_boundary(uint16_t task) {
  std::lock_guard lock(mu_);
  const uint64_t now = monotonic_us();
  JobState& s = jobs_[task];
  if (s.started_us == 0) {
    s.started_us = now;
    return;
  }
  // A sleep ends the job only after half a period: a burst of zero-length
  // sleeps cannot reset the task's rate window.
  const uint64_t period = decider_.task_period_us(task);
  if (now - s.started_us >= period / 2) {
    ++s.job;
    s.started_us = now;
  }
}

uint16_t Monitor::task_priority(uint16_t task) const {
  std::lock_guard lock(mu_);
  return decider_.task_priority(task);
}

uint32_t Monitor::job(uint16_t task) const {
  std::lock_guard lock(mu_);
  auto it = jobs_.find(task);
  return it == jobs_.end() ? 0 : it->second.job;
}

void Monitor::task_exited(uint16_t task) {
  std::lock_guard lock(mu_);
  // Only the actuators this task may command: the end of one task's session
  // must not override what the others are doing.
  const uint32_t devices = task < task_devices_.size() ? task_devices_[task] : UINT32_MAX;
  drive_safe_state_locked(fmt::format("task {} exited", task), devices);
  jobs_.erase(task);
}

std::vector<DeviceFailure> Monitor::drive_safe_state(const std::string& why) {
  std::lock_guard lock(mu_);
  return drive_safe_state_locked(why);
}

std::vector<DeviceFailure> Monitor::drive_safe_state_locked(const std::string& why,
                                                            uint32_t devices) {
  audit_.event("safe-state", why);
  std::vector<DeviceFailure> failed;
  for (uint16_t d = 0; d < decider_.device_count(); ++d) {
    if (d < 32 && (devices & (1u << d)) == 0) continue;
    const core::DeviceRecord& rec = decider_.device(d);
    if ((rec.role & core::kRoleActuator) == 0) continue;
    core::Verdict v{};
    if (!decider_.safe_state(d, &v)) continue;
    if (int err = perform_emits(v, rec.ten_bit != 0); err != 0) {
      auto it = buses_.find(v.bus);
      const std::string cause =
          it == buses_.end() ? "" : emits_inexpressible(*it->second, v, rec.ten_bit);
      audit_.event("fault",
                   fmt::format("safe state of device {} (i2c-{} 0x{:02x}) failed: errno {}{}{}", d,
                               rec.bus, rec.addr, err, cause.empty() ? "" : ": ", cause));
      failed.push_back({d, err});
    }
  }
  return failed;
}

int Monitor::sample_device_locked(uint16_t d) {
  const core::DeviceRecord& rec = decider_.device(d);
  if (rec.sample_len == 0 || rec.sample_len > core::kMaxSampleBytes) return 0;
  auto it = buses_.find(rec.bus);
  if (it == buses_.end()) return ENODEV;
  Sample s;
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
      samples_.erase(d);  // a failed sample makes the signal unavailable (fail closed)
      return err;
    }
  }
  bus::Msg rw[2] = {
      w, {rec.addr, static_cast<uint16_t>(ten | gate::kMsgRead), rec.sample_len, s.bytes.data()}};
  if (int err =
          it->second->transfer(combined ? std::span<bus::Msg>(rw) : std::span<bus::Msg>(rw + 1, 1));
      err != 0) {
    samples_.erase(d);
    return err;
  }
  s.len = rw[1].len;
  s.taken_at_us = monotonic_us();
  samples_[d] = s;
  return 0;
}

std::vector<DeviceFailure> Monitor::sample_all() {
  std::lock_guard lock(mu_);
  std::vector<DeviceFailure> failed;
  for (uint16_t d = 0; d < decider_.device_count(); ++d) {
    if ((decider_.device(d).role & core::kRoleSensor) == 0) continue;
    if (int err = sample_device_locked(d); err != 0) failed.push_back({d, err});
  }
  return failed;
}

void Monitor::start_sampling() {
  std::lock_guard lock(mu_);
  if (sampler_.joinable()) return;
  sampler_stop_ = false;
  sampler_ = std::thread([this] {
    std::map<uint16_t, uint64_t> due;
    std::unique_lock held(mu_);
    while (!sampler_stop_) {
      const uint64_t now = monotonic_us();
      uint64_t next = now + 100000;
      for (uint16_t d = 0; d < decider_.device_count(); ++d) {
        const core::DeviceRecord& rec = decider_.device(d);
        if (!(rec.role & core::kRoleSensor) || rec.sample_period_us == 0) continue;
        uint64_t& at = due[d];
        if (at <= now) {
          sample_device_locked(d);
          at = now + rec.sample_period_us;
        }
        next = std::min(next, at);
      }
      sampler_cv_.wait_for(held, std::chrono::microseconds(next - std::min(next, monotonic_us())),
                           [this] { return sampler_stop_; });
    }
  });
}

void Monitor::stop_sampling() {
  {
    std::lock_guard lock(mu_);
    sampler_stop_ = true;
  }
  sampler_cv_.notify_all();
  if (sampler_.joinable()) sampler_.join();
}

}  // namespace contego::monitor
