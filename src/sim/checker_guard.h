// Protection on: every bus operation of a simulated task goes through the
// real trusted core (core::Checker loaded with a compiled policy image), and
// only the bytes of its verdict reach the device models. The trusted side
// samples its sensors itself, on each sensor's declared period, directly on
// the virtual bus, and keeps the readings tasks made through it; a command is
// judged against them exactly as the monitor judges (readings/sensor_readings.h).
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
#include "readings/sensor_readings.h"
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
  void wrote(uint16_t addr, const std::vector<uint8_t>& bytes) override;
  void read(const std::string& task, const BusOp& op, const std::vector<uint8_t>& data,
            uint64_t now_us) override;

  const core::Checker& checker() const { return *checker_; }

 private:
  CheckerGuard(bus::VirtualBus& bus, std::vector<std::string> task_names, bool observe);
  static uint32_t read_sample(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                              uint64_t* taken_at_us);
  uint16_t task_id(const std::string& name) const;

  bus::VirtualBus& bus_;
  std::vector<std::string> task_names_;
  bool observe_;
  std::unique_ptr<core::Checker> checker_;  // large: kept off the stack
  // The readings a command is judged against, kept as the monitor keeps them.
  readings::SensorReadings readings_;
  std::vector<uint64_t> sample_due_us_;  // by device id: the next own sample
  uint16_t checking_task_ = core::kNoTask;
  uint64_t checking_now_us_ = 0;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_CHECKER_GUARD_H_
