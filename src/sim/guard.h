// What stands between the simulated tasks and the device models.
//
// With protection off the PassThroughGuard hands every write to the bus as
// the task sent it. With protection on, CheckerGuard (checker_guard.h) runs
// the real trusted core on each transaction and only the bytes of its
// verdict reach the devices.
#ifndef CONTEGO_SIM_GUARD_H_
#define CONTEGO_SIM_GUARD_H_

#include <cstdint>
#include <string>
#include <vector>

#include "contego/core/verdict.h"

#include "sim/world.h"

namespace contego::sim {

struct GuardResult {
  core::Decision decision = core::Decision::kAllow;
  core::Reason reason = core::Reason::kAllowed;
  uint16_t addr = 0;                        // where the emits go
  std::vector<std::vector<uint8_t>> emits;  // writes to perform, in order
  // The checker judged the request a violation (in observe mode the request
  // still goes through unchanged).
  bool violation = false;
};

class Guard {
 public:
  virtual ~Guard() = default;
  // Decides about one operation of `task` in its job `job` (1-based) at `now_us`.
  virtual GuardResult check(const std::string& task, uint64_t job, const BusOp& op,
                            uint64_t now_us) = 0;
  // Called once per simulation step before the tasks run: the trusted side
  // samples its sensors here.
  virtual void tick(uint64_t /*now_us*/) {}
  // What the bus performed after check(): a write's bytes (each emit), and a
  // read `task` made, with its pointer bytes and the data the device returned
  // (the trusted side keeps sensor readings from them).
  virtual void wrote(uint16_t /*addr*/, const std::vector<uint8_t>& /*bytes*/) {}
  virtual void read(const std::string& /*task*/, const BusOp& /*op*/,
                    const std::vector<uint8_t>& /*data*/, uint64_t /*now_us*/) {}
};

// Protection off: the bus sees exactly what the tasks send.
class PassThroughGuard : public Guard {
 public:
  GuardResult check(const std::string&, uint64_t, const BusOp& op, uint64_t) override {
    GuardResult r;
    r.addr = op.addr;
    if (op.kind == BusOp::Kind::kWrite) r.emits.push_back(op.bytes);
    return r;
  }
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_GUARD_H_
