// Table 1, infusion pump: a syringe-pump motor driver (register map at
// 0x50: rate in uL/h, direction), an encoder counting the delivered volume
// (0x51) and a screen (0x3D), as declared in policies/pump.policy. The
// infusion task runs the motor at the prescribed rate until the encoder
// shows the prescribed dose.
//
// The example policy prescribes 5000 uL at 200 uL/h, i.e. 25 hours: the
// scenarios run the task once a minute of virtual time (jobs are numbered
// explicitly, so the per-job rate limit means the same thing).
#ifndef CONTEGO_SIM_PUMP_H_
#define CONTEGO_SIM_PUMP_H_

#include <map>
#include <memory>
#include <string>

#include "sim/sim_bus.h"
#include "sim/world.h"

namespace contego::sim {

class InfusionController : public Controller {
 public:
  InfusionController(std::string task, uint64_t period_us, int rate, int dose)
      : Controller(std::move(task), period_us), rate_(rate), dose_(dose) {}
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;

 private:
  int rate_;  // uL/h
  int dose_;  // uL
};

class PumpWorld : public World {
 public:
  PumpWorld(const std::map<std::string, std::string>& settings, uint64_t seed);
  void step(uint64_t now_us, uint64_t dt_us) override;

 private:
  int rate() const;
  InfusionController infusion_;
  std::shared_ptr<RegisterFile> pump_, encoder_, screen_;
  int dose_;
  double delivered_ul_ = 0.0;
  double max_rate_ = 0.0;
  double dose_reached_s_ = -1.0;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_PUMP_H_
