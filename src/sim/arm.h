// The paper's Fig. 1 platform: a 6-channel robotic arm on a PCA9685 servo
// controller picking objects from an assembly line and dropping them at a
// station, driven like tutRPi/6DOF-Robot-Arm drives it (Adafruit PCA9685
// library, 60 Hz, set_pwm as four single-byte register writes). Channel 5 is
// the gripper: 420 opens it, 577 closes it (the arm code's open()/close();
// the paper prints the two labels the other way round).
#ifndef CONTEGO_SIM_ARM_H_
#define CONTEGO_SIM_ARM_H_

#include <map>
#include <memory>
#include <string>

#include "sim/world.h"

namespace contego::sim {

// The four writes of Adafruit's set_pwm(channel, on, off).
std::vector<BusOp> pca9685_set_pwm(uint16_t addr, int channel, uint16_t on, uint16_t off);

// The two tasks of policies/arm.policy. arm_init (one job) initialises the
// controller like the Adafruit library (PCA9685() then set_pwm_freq(60)) and
// puts the arm in its drop pose. gripper moves one servo per job: the first
// job opens the gripper, then every four jobs: base to the pick pose, close
// the gripper, base to the drop pose, open the gripper.
class ArmInitController : public Controller {
 public:
  using Controller::Controller;
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
};

class GripperController : public Controller {
 public:
  GripperController(std::string task, uint64_t period_us, uint64_t offset_us)
      : Controller(std::move(task), period_us, offset_us) {}
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
};

class ArmWorld : public World {
 public:
  ArmWorld(const std::map<std::string, std::string>& settings, uint64_t seed);
  void on_write(uint64_t now_us, uint16_t addr, std::span<const uint8_t> bytes) override;
  void step(uint64_t now_us, uint64_t dt_us) override;

  enum class Grip : uint8_t { kLimp, kOpen, kClosed, kBetween, kJammed };
  Grip grip() const { return grip_; }
  int handled() const { return handled_; }

 private:
  double effective_pulse(int channel) const;  // in 60 Hz ticks; 0 = no output, -1 = full on

  ArmInitController init_;
  GripperController gripper_;
  std::shared_ptr<bus::Pca9685> pca_;
  uint64_t period_us_;
  uint64_t now_us_ = 0;
  Grip grip_ = Grip::kLimp;
  bool holding_ = false;
  bool object_waiting_ = false;
  uint64_t next_arrival_us_;
  int handled_ = 0;
  int lost_ = 0;
  int missed_ = 0;
  int bad_pulses_ = 0;
  double jammed_s_ = 0.0;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_ARM_H_
