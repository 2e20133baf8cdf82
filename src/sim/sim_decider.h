// The trusted core as the simulator's monitor drives it, in both modes of
// `contego sim` (virtual time: monitor_guard.h; real time: the CLI's
// run_realtime). It remembers what it decided last and counts decisions;
// with protection off (observe mode) it only watches: the core still judges
// every request, so a summary can say when the first violation happened,
// but every request acts as the task sent it and no safe state is driven.
//
// Thread-safety: the monitor serialises the Decider calls; last() and
// stats() may be read from any thread.
#ifndef CONTEGO_SIM_SIM_DECIDER_H_
#define CONTEGO_SIM_SIM_DECIDER_H_

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "base/result.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "sim/runner.h"

namespace contego::sim {

struct PolicyImage {
  std::vector<uint8_t> bytes;           // as the compiler serialised it
  std::vector<std::string> task_names;  // by task id
  monitor::NameTable names;             // all the policy's names (optional: drop lines name rules)
};

class SimDecider final : public monitor::Decider {
 public:
  // Decision times in stats() count from `t0_us`.
  explicit SimDecider(bool enforce, uint64_t t0_us = 0) : enforce_(enforce), t0_us_(t0_us) {}
  // Loads (and so verifies) the image; fails with the verifier's reason.
  Status load(const PolicyImage& image);

  // The core's judgement of the last request and what acted.
  struct Last {
    core::Decision decision = core::Decision::kAllow;  // what acted
    core::Reason reason = core::Reason::kAllowed;
    bool violation = false;  // the core's verdict was not "allow"
  };
  Last last() const;
  RunStats stats() const;

  void set_host(const core::Host& host) override { core_.set_host(host); }
  void check(const core::Transaction& tx, core::Verdict* v) override;
  bool safe_state(uint16_t device, core::Verdict* out) override {
    return enforce_ && core_.safe_state(device, out);  // no safe states without protection
  }
  void begin_transfer() override { core_.begin_transfer(); }
  void commit_transfer() override { core_.commit_transfer(); }
  void abort_transfer(core::Decision decision) override { core_.abort_transfer(decision); }
  uint32_t device_count() const override { return core_.device_count(); }
  const core::DeviceRecord& device(uint16_t id) const override { return core_.device(id); }
  uint32_t task_period_us(uint16_t task) const override { return core_.task_period_us(task); }
  uint16_t task_priority(uint16_t task) const override { return core_.task_priority(task); }
  uint32_t task_actuations_per_job(uint16_t task) const override {
    return core_.task_actuations_per_job(task);
  }
  bool latched(uint16_t device) const override { return core_.latched(device); }
  void reset_latch(uint16_t device) override { core_.reset_latch(device); }

 private:
  monitor::CoreDecider core_;
  bool enforce_;
  uint64_t t0_us_;
  mutable std::mutex mu_;
  Last last_;
  RunStats stats_;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_SIM_DECIDER_H_
