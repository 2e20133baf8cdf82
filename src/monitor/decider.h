// Decider: the trusted core as the monitor drives it. CoreDecider
// (core_decider.h) is the real one (core::Checker over a verified image);
// tests and `contego bench` substitute scripted
// deciders to exercise the monitor's own paths (fail-closed errors, safe
// states, audit) independently of any policy.
//
// Thread-safety: none; the monitor serialises every call under its lock.
#ifndef CONTEGO_MONITOR_DECIDER_H_
#define CONTEGO_MONITOR_DECIDER_H_

#include <cstdint>

#include "contego/core/checker.h"
#include "contego/core/host.h"
#include "contego/core/image.h"
#include "contego/core/transaction.h"
#include "contego/core/verdict.h"

namespace contego::monitor {

class Decider {
 public:
  virtual ~Decider() = default;
  virtual void set_host(const core::Host& host) = 0;
  virtual void check(const core::Transaction& tx, core::Verdict* out) = 0;
  virtual bool safe_state(uint16_t device, core::Verdict* out) = 0;
  // What safe_state would write, the model left as it was; scripted
  // deciders keep no model, so theirs is one already.
  virtual bool preview_safe_state(uint16_t device, core::Verdict* out) {
    return safe_state(device, out);
  }
  // The checks of one transfer as one unit (core::Checker's); scripted
  // deciders keep no model, so the defaults do nothing.
  virtual void begin_transfer() {}
  virtual void commit_transfer() {}
  virtual void abort_transfer(core::Decision /*decision*/) {}
  virtual uint32_t device_count() const = 0;
  virtual const core::DeviceRecord& device(uint16_t id) const = 0;
  virtual uint32_t task_period_us(uint16_t task) const = 0;  // 0 = unknown task
  // The policy's priority of the task (larger = more important), 0 = none.
  virtual uint16_t task_priority(uint16_t /*task*/) const { return 0; }
  // Checked commands the task declares per job (N_i of the schedulability
  // test), 0 = none declared.
  virtual uint32_t task_actuations_per_job(uint16_t /*task*/) const { return 0; }
  // Operator reset of a latched device (`contego reset`).
  virtual bool latched(uint16_t /*device*/) const { return false; }
  virtual void reset_latch(uint16_t /*device*/) {}
  // A session of the task ended (core::Checker::end_session).
  // Returns the staged register writes of the task it dropped.
  virtual uint32_t end_session(uint16_t /*task*/) { return 0; }
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_DECIDER_H_
