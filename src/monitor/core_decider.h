// CoreDecider: the monitor's Decider backed by the real core::Checker. Kept
// out of decider.h so that code which never uses the real core (the monitor
// library itself, tests with scripted deciders, `contego bench`) does not
// reference the core's symbols through speculative devirtualisation.
#ifndef CONTEGO_MONITOR_CORE_DECIDER_H_
#define CONTEGO_MONITOR_CORE_DECIDER_H_

#include "monitor/decider.h"

namespace contego::monitor {

// The trusted core. Owns its Checker (large: fixed tables), so allocate it.
class CoreDecider final : public Decider {
 public:
  core::Checker& checker() { return checker_; }
  void set_host(const core::Host& host) override { checker_.set_host(host); }
  void check(const core::Transaction& tx, core::Verdict* out) override { checker_.check(tx, out); }
  bool safe_state(uint16_t device, core::Verdict* out) override {
    return checker_.safe_state(device, out);
  }
  bool preview_safe_state(uint16_t device, core::Verdict* out) override {
    return checker_.safe_state(device, out, false);
  }
  void begin_transfer() override { checker_.begin_transfer(); }
  void commit_transfer() override { checker_.commit_transfer(); }
  void abort_transfer(core::Decision decision) override { checker_.abort_transfer(decision); }
  uint32_t device_count() const override { return checker_.device_count(); }
  const core::DeviceRecord& device(uint16_t id) const override { return checker_.device(id); }
  uint32_t task_period_us(uint16_t task) const override {
    return task < checker_.task_count() ? checker_.task(task).period_us : 0;
  }
  uint16_t task_priority(uint16_t task) const override {
    return task < checker_.task_count() ? checker_.task(task).priority : 0;
  }
  uint32_t task_actuations_per_job(uint16_t task) const override {
    return task < checker_.task_count() ? checker_.task(task).actuations_per_job : 0;
  }
  bool latched(uint16_t device) const override { return checker_.latched(device); }
  void reset_latch(uint16_t device) override { checker_.reset_latch(device); }
  uint32_t end_session(uint16_t task) override { return checker_.end_session(task); }

 private:
  core::Checker checker_;
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_CORE_DECIDER_H_
