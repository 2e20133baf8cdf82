// The paper's case study: a GoPiGo2 rover following a line with the vendor's
// line-follower control loop (devices spec 2.3), on a stadium-shaped track.
//
// Plant: differential drive, two wheels of radius 3.25 cm, 18 encoder ticks
// per revolution, first-order motor lag, seeded speed noise. Sensor: the red
// line follower's five reflectance values computed from the rover's pose over
// the line, with the vendor's white/black calibration and seeded noise.
#ifndef CONTEGO_SIM_ROVER_H_
#define CONTEGO_SIM_ROVER_H_

#include <array>
#include <deque>
#include <map>
#include <memory>
#include <string>

#include "sim/world.h"

namespace contego::sim {

// pos = sum (raw_i - white_i) * 100 / (black_i - white_i) * w_i, float as the vendor.
double line_position(const std::array<uint16_t, 5>& raw);

// The vendor line-follower loop as a periodic task: each job reads the
// sensor, then set_speed(s) (two frames 100 ms apart) and a direction frame.
class LineFollowerController : public Controller {
 public:
  struct Options {
    std::string task = "follower";
    uint64_t period_us = 200'000;
    uint8_t fwd_opcode = 105;  // Python library fwd(); the C library sends 119
  };
  explicit LineFollowerController(Options options)
      : Controller(options.task, options.period_us), o_(std::move(options)) {}
  void release(const Job& job, Port& port, std::vector<TimedOp>& ops) override;
  double last_position() const { return last_pos_; }

 private:
  Options o_;
  double last_pos_ = 0.0;
};

class RoverWorld : public World {
 public:
  // Recognised settings (scenario `set` lines): task, period, fwd_opcode,
  // straight (m), radius (m), speed_noise, sensor_noise.
  RoverWorld(const std::map<std::string, std::string>& settings, uint64_t seed);

  void step(uint64_t now_us, uint64_t dt_us) override;

  double distance_cm() const;
  // Over the recent history (the trace's speed column).
  double speed_cm_s() const;
  // Signed wheel commands (-255..255) the firmware drives, from its motion
  // and speeds: the firmware's speed2 / motor2 is the left wheel.
  int left_command() const;
  int right_command() const;  // from the encoders: mean of both wheels
  // Signed distance (m) from a point to the line's centre (positive outside the loop).
  double line_offset(double x, double y) const;
  // Arc length (m) of the line point nearest to (x, y), from the start, counter-clockwise.
  double track_position(double x, double y) const;

 private:
  void update_sensor();

  LineFollowerController controller_;
  std::shared_ptr<bus::GoPiGo2> gopigo_;
  std::shared_ptr<bus::LineFollower> line_;
  double straight_m_ = 2.0;
  double radius_m_ = 1.0;
  double speed_noise_ = 0.03;
  double sensor_noise_ = 6.0;
  double max_rev_per_s_ = 1.4;    // wheel speed at speed byte 255
  double motor_lag_s_ = 0.08;     // first-order time constant of a wheel
  double sensor_ahead_m_ = 0.07;  // sensor bar ahead of the axle
  // Pose and wheels.
  double x_ = 0.0, y_ = 0.0, heading_ = 0.0;
  double w_left_ = 0.0, w_right_ = 0.0;          // wheel angular speed (rad/s)
  double angle_left_ = 0.0, angle_right_ = 0.0;  // accumulated |angle| (rad)
  uint64_t ticks_left_ = 0, ticks_right_ = 0;
  double off_line_s_ = 0.0;
  double progress_m_ = 0.0;  // along the line, unwrapped (negative = backwards)
  double last_s_ = 0.0;
  double max_speed_ = 0.0;
  uint64_t now_us_ = 0;
  std::deque<std::pair<uint64_t, double>> history_;  // (time, distance) for the speed
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_ROVER_H_
