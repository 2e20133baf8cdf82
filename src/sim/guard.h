// What stands between the simulated tasks and the device models.
//
// With protection off the PassThroughGuard performs every operation on the
// bus as the task sent it. With protection on, MonitorGuard (monitor_guard.h)
// hands each operation to the real monitor, which has the trusted core decide
// it and performs only the bytes of the verdict on the bus.
#ifndef CONTEGO_SIM_GUARD_H_
#define CONTEGO_SIM_GUARD_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "contego/core/verdict.h"

#include "bus/bus.h"
#include "sim/world.h"

namespace contego::sim {

struct GuardResult {
  core::Decision decision = core::Decision::kAllow;
  core::Reason reason = core::Reason::kAllowed;
  uint16_t addr = 0;                         // where the emits went
  std::vector<std::vector<uint8_t>> emits;   // the writes that reached the bus, in order
  std::optional<std::vector<uint8_t>> data;  // a read's bytes, when it was performed
  // The checker judged the request a violation (in observe mode the request
  // still goes through unchanged).
  bool violation = false;
};

class Guard {
 public:
  virtual ~Guard() = default;
  // Decides about one operation of `task` at `now_us` and performs what the
  // decision allows on the bus.
  virtual GuardResult perform(const std::string& task, const BusOp& op, uint64_t now_us) = 0;
  // A job of `task` was released at `now_us` (the trusted side's job grid
  // starts at the task's first release).
  virtual void released(const std::string& /*task*/, uint64_t /*now_us*/) {}
  // Called once per simulation step before the tasks run: the trusted side
  // samples its sensors here.
  virtual void tick(uint64_t /*now_us*/) {}
};

// Protection off: the bus sees exactly what the tasks send.
class PassThroughGuard : public Guard {
 public:
  explicit PassThroughGuard(bus::Bus& bus) : bus_(bus) {}
  GuardResult perform(const std::string&, const BusOp& op, uint64_t) override;

 private:
  bus::Bus& bus_;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_GUARD_H_
