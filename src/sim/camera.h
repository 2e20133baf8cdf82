// Table 1, surveillance: a camera on pan/tilt servos (PCA9685 channels 0
// and 1 at 0x40), a motion sensor (0x30) and a siren (0x21), as declared in
// policies/camera.policy. The tracker task patrols the allowed pan range;
// the alarm task sounds the siren while the sensor reports an object.
// Angles: 375 ticks is straight ahead, 175 ticks are 60 degrees.
#ifndef CONTEGO_SIM_CAMERA_H_
#define CONTEGO_SIM_CAMERA_H_

#include <map>
#include <memory>
#include <string>

#include "sim/sim_bus.h"
#include "sim/world.h"

namespace contego::sim {

double camera_angle_deg(double ticks);

class PatrolController : public Controller {
 public:
  using Controller::Controller;
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
};

class SirenController : public Controller {
 public:
  using Controller::Controller;
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
};

class CameraWorld : public World {
 public:
  CameraWorld(const std::map<std::string, std::string>& settings, uint64_t seed);
  void step(uint64_t now_us, uint64_t dt_us) override;

 private:
  PatrolController tracker_;
  SirenController alarm_;
  std::shared_ptr<bus::Pca9685> servos_;
  std::shared_ptr<RegisterFile> motion_, siren_;
  double pan_deg_ = 0.0, tilt_deg_ = 0.0;
  double max_abs_pan_ = 0.0, outside_s_ = 0.0, false_siren_s_ = 0.0;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_CAMERA_H_
