#include "sim/checker_guard.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "sim/sim_bus.h"

namespace contego::sim {

CheckerGuard::CheckerGuard(bus::VirtualBus& bus, std::vector<std::string> task_names, bool observe)
    : bus_(bus),
      task_names_(std::move(task_names)),
      observe_(observe),
      checker_(std::make_unique<core::Checker>()) {}

Result<std::unique_ptr<CheckerGuard>> CheckerGuard::create(const PolicyImage& image,
                                                           bus::VirtualBus& bus, bool observe) {
  std::unique_ptr<CheckerGuard> g(new CheckerGuard(bus, image.task_names, observe));
  const core::LoadResult lr =
      g->checker_->load(image.bytes.data(), static_cast<uint32_t>(image.bytes.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(std::string("the checker refused the policy image: ") +
                      core::load_status_name(lr.status) + " (section " +
                      std::to_string(lr.section) + ", record " + std::to_string(lr.index) + ")");
  }
  core::Host host{};
  host.context = g.get();
  host.read_sample = &CheckerGuard::read_sample;
  host.audit = nullptr;
  g->checker_->set_host(host);
  g->readings_.reset(g->checker_->device_count());
  for (uint16_t d = 0; d < g->checker_->device_count(); ++d) {
    g->readings_.describe(d, g->checker_->device(d));
  }
  g->sample_due_us_.assign(g->checker_->device_count(), 0);
  return g;
}

uint32_t CheckerGuard::read_sample(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                                   uint64_t* taken_at_us) {
  auto* self = static_cast<CheckerGuard*>(context);
  const readings::Reading* r =
      self->readings_.for_check(self->checking_task_, device, self->checking_now_us_);
  if (r == nullptr) return 0;
  const uint32_t n = std::min(capacity, r->len);
  std::memcpy(buf, r->bytes.data(), n);
  *taken_at_us = r->taken_at_us;
  return n;
}

void CheckerGuard::wrote(uint16_t addr, const std::vector<uint8_t>& bytes) {
  readings_.on_write(1, addr, bytes);
}

void CheckerGuard::read(const std::string& task, const BusOp& op, const std::vector<uint8_t>& data,
                        uint64_t now_us) {
  readings_.on_read(task_id(task), 1, op.addr, op.bytes, data, now_us);
}

void CheckerGuard::tick(uint64_t now_us) {
  for (uint16_t d = 0; d < sample_due_us_.size(); ++d) {
    const core::DeviceRecord& rec = checker_->device(d);
    if ((rec.role & core::kRoleSensor) == 0 || rec.sample_len == 0) continue;
    if (now_us < sample_due_us_[d]) continue;
    // The device's sample request, then its sample, in one combined transfer.
    std::vector<uint8_t> out(rec.sample_len);
    const std::span<const uint8_t> request(rec.sample_request, rec.sample_request_len);
    if (bus_read(bus_, rec.addr, request, out) == 0) {
      readings_.on_sample(d, out, now_us);
    } else {
      readings_.on_sample_failed(d);
    }
    const uint64_t period = rec.sample_period_us ? rec.sample_period_us : 10'000;
    sample_due_us_[d] = now_us + period;
  }
}

uint16_t CheckerGuard::task_id(const std::string& name) const {
  for (size_t i = 0; i < task_names_.size(); ++i) {
    if (task_names_[i] == name) return static_cast<uint16_t>(i);
  }
  return core::kNoTask;
}

GuardResult CheckerGuard::check(const std::string& task, uint64_t job, const BusOp& op,
                                uint64_t now_us) {
  core::Transaction tx{};
  tx.task = task_id(task);
  tx.bus = 1;
  tx.kind = op.kind == BusOp::Kind::kWrite ? core::TxKind::kWrite : core::TxKind::kRead;
  tx.addr = op.addr;
  tx.job = static_cast<uint32_t>(job);
  tx.len = static_cast<uint32_t>(op.bytes.size());
  tx.bytes = op.bytes.data();
  tx.now_us = now_us;
  checking_task_ = tx.task;
  checking_now_us_ = now_us;
  auto verdict = std::make_unique<core::Verdict>();
  checker_->check(tx, verdict.get());

  GuardResult r;
  r.violation = verdict->decision != core::Decision::kAllow;
  if (observe_) {  // protection off: the task's bytes go through as sent
    r.addr = op.addr;
    if (op.kind == BusOp::Kind::kWrite) r.emits.push_back(op.bytes);
    return r;
  }
  r.decision = verdict->decision;
  r.reason = verdict->reason;
  r.addr = verdict->addr;
  size_t off = 0;
  for (uint8_t i = 0; i < verdict->emit_count && i < core::kMaxEmits; ++i) {
    const size_t len = verdict->emit_len[i];
    if (off + len > core::kMaxEmitBytes) break;  // malformed verdict: perform nothing more
    r.emits.emplace_back(verdict->emit_bytes + off, verdict->emit_bytes + off + len);
    off += len;
  }
  return r;
}

}  // namespace contego::sim
