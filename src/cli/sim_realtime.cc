#include "cli/sim_realtime.h"

#include <atomic>
#include <chrono>
#include <cstring>
#include <mutex>
#include <thread>

#include "intercept/seccomp/supervisor.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"

namespace contego::cli {
namespace {

// The real core, counting what it decides; with protection off it only
// watches: every write goes to the bus as the program sent it.
class SimDecider final : public monitor::Decider {
 public:
  SimDecider(bool enforce, uint64_t t0_us) : enforce_(enforce), t0_us_(t0_us) {}
  monitor::CoreDecider& core() { return core_; }
  sim::RunStats stats() const {
    std::lock_guard lock(mu_);
    return stats_;
  }

  void set_host(const core::Host& host) override { core_.set_host(host); }
  void check(const core::Transaction& tx, core::Verdict* v) override {
    core_.check(tx, v);
    std::lock_guard lock(mu_);
    if (tx.kind != core::TxKind::kWrite) {
      ++stats_.reads;
      if (!enforce_) pass(tx, v);
      return;
    }
    ++stats_.writes;
    if (v->decision != core::Decision::kAllow) {
      ++stats_.violations;
      if (!stats_.first_violation_us) {
        stats_.first_violation_us = tx.now_us > t0_us_ ? tx.now_us - t0_us_ : 0;
      }
    }
    if (!enforce_) pass(tx, v);
    switch (v->decision) {
      case core::Decision::kAllow:
        ++stats_.allowed;
        break;
      case core::Decision::kIgnore:
        ++stats_.ignored;
        break;
      case core::Decision::kFailsafe:
        ++stats_.replaced;
        break;
      case core::Decision::kReject:
        ++stats_.rejected;
        break;
    }
  }
  bool safe_state(uint16_t device, core::Verdict* out) override {
    return enforce_ && core_.safe_state(device, out);  // no safe states without protection
  }
  uint32_t device_count() const override { return core_.device_count(); }
  const core::DeviceRecord& device(uint16_t id) const override { return core_.device(id); }
  uint32_t task_period_us(uint16_t task) const override { return core_.task_period_us(task); }

 private:
  // Protection off: the request as sent.
  static void pass(const core::Transaction& tx, core::Verdict* v) {
    const uint16_t device = v->device;
    *v = core::Verdict{};
    v->decision = core::Decision::kAllow;
    v->reason =
        tx.kind == core::TxKind::kWrite ? core::Reason::kAllowed : core::Reason::kReadAllowed;
    v->device = device;
    v->bus = tx.bus;
    v->addr = tx.addr;
    if (tx.kind == core::TxKind::kWrite && tx.len <= core::kMaxEmitBytes) {
      v->emit_count = 1;
      v->emit_len[0] = static_cast<uint16_t>(tx.len);
      v->emit_bytes_used = static_cast<uint16_t>(tx.len);
      std::memcpy(v->emit_bytes, tx.bytes, tx.len);
    }
  }

  monitor::CoreDecider core_;
  bool enforce_;
  uint64_t t0_us_;
  mutable std::mutex mu_;
  sim::RunStats stats_;
};

}  // namespace

Result<sim::RunResult> run_realtime(const RealtimeRequest& req) {
  const sim::Scenario& sc = req.scenario;
  auto made = sim::make_world(sc, sc.seed);
  if (!made) return make_error(made.error());
  std::unique_ptr<sim::World> world = std::move(*made);
  bus::VirtualBus vbus;
  world->attach(vbus);

  auto decider = std::make_unique<SimDecider>(req.protect, monitor::monotonic_us());
  const auto lr = decider->core().checker().load(req.image.bytes.data(),
                                                 static_cast<uint32_t>(req.image.bytes.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(std::string("the checker refused the policy image: ") +
                      core::load_status_name(lr.status));
  }
  uint16_t task = core::kNoTask;
  for (size_t i = 0; i < req.image.task_names.size(); ++i) {
    if (req.image.task_names[i] == req.task) task = static_cast<uint16_t>(i);
  }
  if (task == core::kNoTask) return make_error("the policy declares no task '" + req.task + "'");

  monitor::AuditLog audit;
  if (!req.audit_path.empty()) {
    auto st = audit.open(req.audit_path);
    if (!st) return make_error(st.error());
  }
  monitor::Monitor mon(*decider, audit);
  mon.add_bus(1, &vbus);
  mon.set_task_names(req.image.task_names);
  mon.sample_all();
  mon.start_sampling();

  sim::RunResult result;
  result.label = req.label;
  result.columns.push_back("time_s");
  for (auto& c : world->columns()) result.columns.push_back(c);

  // The plant: a fixed step in real time, under the bus lock so the monitor
  // never sees a half-updated device. Late steps are caught up at once.
  std::atomic<bool> stop{false};
  std::thread plant([&] {
    // The plant's clock starts with the program's first bus transfer, so
    // that times in the program (its attack window) and in the trace agree
    // however long the interpreter takes to start.
    while (!stop.load() && mon.decisions() == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t limit = sc.duration_us + 1'000'000;
    for (uint64_t t = sc.step_us; !stop.load() && t <= limit; t += sc.step_us) {
      std::this_thread::sleep_until(t0 + std::chrono::microseconds(t));
      vbus.with_lock([&] {
        world->step(t, sc.step_us);
        if (t % sc.trace_us == 0) {
          std::vector<double> row{static_cast<double>(t) * 1e-6};
          for (double v : world->sample()) row.push_back(v);
          result.rows.push_back(std::move(row));
        }
      });
    }
  });

  intercept::seccomp::Options opts;
  opts.task = task;
  opts.argv = req.argv;
  auto rr = intercept::seccomp::run(opts, mon);
  stop = true;
  plant.join();
  mon.stop_sampling();
  if (!rr) return make_error("running " + req.argv.front() + ": " + rr.error());
  if (rr->exit_code != 0 || rr->signal != 0) {
    return make_error(req.argv.front() + " failed (exit " + std::to_string(rr->exit_code) +
                      ", signal " + std::to_string(rr->signal) + ")");
  }
  result.metrics = world->metrics();
  result.stats = decider->stats();
  return result;
}

}  // namespace contego::cli
