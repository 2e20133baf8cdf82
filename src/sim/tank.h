// Table 1, water monitoring: a tank whose level and temperature a sensor
// reports (register map at 0x48), a buzzer (0x20) and an alert display
// (0x3C), as declared in policies/tank.policy. The monitor task sounds the
// buzzer only while the level is above 800 mm or the temperature leaves
// 5.0..40.0 degC (the paper's INV_W).
#ifndef CONTEGO_SIM_TANK_H_
#define CONTEGO_SIM_TANK_H_

#include <map>
#include <memory>
#include <string>

#include "sim/sim_bus.h"
#include "sim/world.h"

namespace contego::sim {

class TankMonitor : public Controller {
 public:
  using Controller::Controller;
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
};

class TankWorld : public World {
 public:
  TankWorld(const std::map<std::string, std::string>& settings, uint64_t seed);
  void step(uint64_t now_us, uint64_t dt_us) override;

 private:
  bool abnormal() const;
  TankMonitor monitor_;
  std::shared_ptr<RegisterFile> sensor_, buzzer_, display_;
  double level_mm_ = 600.0;
  double temp_dc_ = 200.0;  // 0.1 degC
  double false_alarm_s_ = 0.0, missed_alarm_s_ = 0.0, alarm_s_ = 0.0;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_TANK_H_
