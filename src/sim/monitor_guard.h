// Protection on: every bus operation of a simulated task goes to the real
// monitor (monitor/monitor.h), run in virtual time: its clock is the
// simulation's, its bus the virtual one. The monitor has the trusted core
// (loaded with a compiled policy image) decide each operation and performs
// only the bytes of the verdict; it samples its sensors on their declared
// periods and keeps the readings tasks made through it, exactly as on a
// device.
//
// Observe mode (protection off, but watching): the core judges every
// operation so the summary can say when the first violation happened, and
// the task's own bytes go to the bus unchanged (sim_decider.h).
#ifndef CONTEGO_SIM_MONITOR_GUARD_H_
#define CONTEGO_SIM_MONITOR_GUARD_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "base/clock.h"
#include "base/result.h"
#include "bus/virtual_bus.h"
#include "monitor/audit_log.h"
#include "monitor/monitor.h"
#include "sim/guard.h"
#include "sim/sim_decider.h"

namespace contego::sim {

// The simulated bus as the monitor sees it: the virtual bus, with the
// single-message writes performed while `recording` kept (what reached the
// devices, for the plant's event log).
class RecordingBus final : public bus::Bus {
 public:
  explicit RecordingBus(bus::Bus& bus) : bus_(bus) {}
  uint64_t funcs() const override { return bus_.funcs(); }
  int transfer(std::span<bus::Msg> msgs) override;
  int quick(uint16_t addr, bool read) override { return bus_.quick(addr, read); }
  Status expressible(std::span<const bus::Msg> msgs) const override {
    return bus_.expressible(msgs);
  }

  bool recording = false;
  uint16_t written_addr = 0;
  std::vector<std::vector<uint8_t>> written;

 private:
  bus::Bus& bus_;
};

class MonitorGuard : public Guard {
 public:
  // Loads (and so verifies) `image`; fails with the verifier's reason.
  static Result<std::unique_ptr<MonitorGuard>> create(const PolicyImage& image, bus::Bus& bus,
                                                      bool observe);

  GuardResult perform(const std::string& task, const BusOp& op, uint64_t now_us) override;
  void released(const std::string& task, uint64_t now_us) override;
  void tick(uint64_t now_us) override;

 private:
  MonitorGuard(bus::Bus& bus, std::vector<std::string> task_names, bool observe);
  uint16_t task_id(const std::string& name) const;

  std::vector<std::string> task_names_;
  bool observe_;
  ManualClock clock_;
  RecordingBus bus_;
  SimDecider decider_;
  monitor::AuditLog audit_;  // discards
  std::unique_ptr<monitor::Monitor> monitor_;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_MONITOR_GUARD_H_
