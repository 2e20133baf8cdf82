// Protection on: every bus operation of a simulated task goes through the
// real trusted core (core::Checker loaded with a compiled policy image), and
// only the bytes of its verdict reach the device models. The trusted side
// samples its sensors itself, on each sensor's declared period, directly on
// the virtual bus (never through a task).
//
// Observe mode (protection off, but watching): the checker judges every
// operation so the summary can say when the first violation happened, and
// the task's own bytes go to the bus unchanged.
#ifndef CONTEGO_SIM_CHECKER_GUARD_H_
#define CONTEGO_SIM_CHECKER_GUARD_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "contego/core/checker.h"

#include "base/result.h"
#include "bus/virtual_bus.h"
#include "sim/guard.h"

namespace contego::sim {

struct PolicyImage {
  std::vector<uint8_t> bytes;           // as the compiler serialised it
  std::vector<std::string> task_names;  // by task id
};

class CheckerGuard : public Guard {
 public:
  // Loads (and so verifies) `image`; fails with the verifier's reason.
  static Result<std::unique_ptr<CheckerGuard>> create(const PolicyImage& image,
                                                      bus::VirtualBus& bus, bool observe);

  GuardResult check(const std::string& task, uint64_t job, const BusOp& op,
                    uint64_t now_us) override;
  void tick(uint64_t now_us) override;

  const core::Checker& checker() const { return *checker_; }

 private:
  struct Sample {
    std::vector<uint8_t> bytes;
    uint64_t taken_at_us = 0;
    uint64_t next_due_us = 0;
    bool valid = false;
  };
  CheckerGuard(bus::VirtualBus& bus, std::vector<std::string> task_names, bool observe);
  static uint32_t read_sample(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                              uint64_t* taken_at_us);
  uint16_t task_id(const std::string& name) const;

  bus::VirtualBus& bus_;
  std::vector<std::string> task_names_;
  bool observe_;
  std::unique_ptr<core::Checker> checker_;  // large: kept off the stack
  std::vector<Sample> samples_;             // by device id
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_CHECKER_GUARD_H_
