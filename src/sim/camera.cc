#include "sim/camera.h"

#include <algorithm>
#include <cmath>

#include "sim/arm.h"
#include "sim/settings.h"

namespace contego::sim {
namespace {

constexpr uint16_t kServoAddr = 0x40;
constexpr uint16_t kMotionAddr = 0x30;
constexpr uint16_t kSirenAddr = 0x21;
constexpr double kAllowedDeg = 60.0;    // PAN_MIN..PAN_MAX of the policy
constexpr double kSlewDegPerS = 120.0;  // servo speed
constexpr double kTickUs60Hz = 1e6 / 60.0 / 4096.0;

// Patrol: a triangle wave over 250..500 ticks (about -43..+43 degrees), 10 s per sweep.
uint16_t patrol_pan(uint64_t t_us) {
  const uint64_t phase = t_us % 20'000'000;
  const double f = phase < 10'000'000 ? static_cast<double>(phase) / 10e6
                                      : 2.0 - static_cast<double>(phase) / 10e6;
  return static_cast<uint16_t>(250 + std::lround(250.0 * f));
}

// The tracker points the camera past its allowed range (e.g. at a neighbour's window).
class BeyondRange : public Attack {
 public:
  BeyondRange(AttackSpec spec, std::string victim) : Attack(std::move(spec), std::move(victim)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!hits(job, task)) return;
    const auto pulse = static_cast<uint16_t>(spec().param_int("pulse", 620));
    for (auto& op : ops) {
      if (op.is_write(task, kServoAddr, 2) && op.rewrite_word(0x08, pulse)) op.injected = true;
    }
  }
};

// The alarm task sounds the siren with nothing in view.
class FalseSiren : public Attack {
 public:
  FalseSiren(AttackSpec spec, std::string victim) : Attack(std::move(spec), std::move(victim)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!hits(job, task)) return;
    for (auto& op : ops) {
      if (op.is_write(task, kSirenAddr, 2)) {
        op.op.bytes[1] = 1;
        op.injected = true;
      }
    }
  }
};

}  // namespace

double camera_angle_deg(double ticks) { return (ticks - 375.0) * 60.0 / 175.0; }

void PatrolController::release(const Job& job, Port&, std::vector<TimedOp>& ops) {
  uint64_t t = job.release_us;
  auto add = [&](const std::vector<BusOp>& bus_ops) {
    for (const auto& op : bus_ops) ops.push_back({t++, task(), op, false});
  };
  if (job.index == 1) {  // wake the controller at 60 Hz (sleep, prescale, wake)
    add({write_op(kServoAddr, {0x00, 0x11}), write_op(kServoAddr, {0xFE, 0x65}),
         write_op(kServoAddr, {0x00, 0x01})});
  }
  add(pca9685_set_pwm(kServoAddr, 0, 0, patrol_pan(job.release_us)));
  add(pca9685_set_pwm(kServoAddr, 1, 0, 375));
}

void SirenController::release(const Job& job, Port& port, std::vector<TimedOp>& ops) {
  auto r = read_register(port, kMotionAddr, 0x00, 1);
  const uint8_t detected = r && !r->empty() && (*r)[0] ? 1 : 0;
  schedule(ops, job.release_us, kSirenAddr, {0x01, detected});
}

CameraWorld::CameraWorld(const std::map<std::string, std::string>& settings, uint64_t seed)
    : World("camera", derive_seed(seed, 5)),
      tracker_(setting_string(settings, "task", "tracker"),
               setting_duration_us(settings, "period", 100'000)),
      alarm_(setting_string(settings, "alarm_task", "alarm"),
             setting_duration_us(settings, "alarm_period", 1'000'000)),
      servos_(add_device(std::make_shared<bus::Pca9685>(kServoAddr))),
      motion_(add_device(std::make_shared<RegisterFile>(kMotionAddr))),
      siren_(add_device(std::make_shared<RegisterFile>(kSirenAddr))) {
  set_controllers({&tracker_, &alarm_});
  add_column("pan_deg", [this] { return pan_deg_; });
  add_column("tilt_deg", [this] { return tilt_deg_; });
  add_column("object", [this] { return static_cast<double>(motion_->reg(0)); });
  add_column("siren", [this] { return static_cast<double>(siren_->reg(0x01)); });
  add_metric("max_pan_angle", "deg", [this] { return max_abs_pan_; });
  add_metric("time_beyond_range", "s", [this] { return outside_s_; });
  add_metric("false_siren_time", "s", [this] { return false_siren_s_; });
  add_attack("beyond_range", [tracker = tracker_.task()](const AttackSpec& spec) {
    return std::make_unique<BeyondRange>(spec, tracker);
  });
  add_attack("false_siren", [alarm = alarm_.task()](const AttackSpec& spec) {
    return std::make_unique<FalseSiren>(spec, alarm);
  });
}

void CameraWorld::step(uint64_t now_us, uint64_t dt_us) {
  const double dt = static_cast<double>(dt_us) * 1e-6;
  auto follow = [&](double& angle, int channel) {
    const auto o = pwm_output(*servos_, channel);
    if (!o.active || o.full_on) return;  // limp or pinned: the servo stays where it is
    const double target = camera_angle_deg(o.pulse_us / kTickUs60Hz);
    const double limit = std::min(90.0, std::abs(target));  // mechanical end stops
    const double goal = std::copysign(limit, target);
    const double stepmax = kSlewDegPerS * dt;
    angle += std::clamp(goal - angle, -stepmax, stepmax);
  };
  follow(pan_deg_, 0);
  follow(tilt_deg_, 1);
  max_abs_pan_ = std::max(max_abs_pan_, std::abs(pan_deg_));
  if (std::abs(pan_deg_) > kAllowedDeg + 0.5) outside_s_ += dt;
  pan_deg_ += noise_.gaussian(0.02);  // servo jitter
  // Someone walks through the scene for 3 s in every other 15 s slot.
  const uint64_t slot = now_us / 15'000'000;
  const uint64_t in_slot = now_us % 15'000'000;
  const bool present = in_slot >= 5'000'000 && in_slot < 8'000'000 && slot % 2 == 1;
  motion_->set_reg(0, present ? 1 : 0);
  if (siren_->reg(0x01) != 0 && !present) false_siren_s_ += dt;
}

}  // namespace contego::sim
