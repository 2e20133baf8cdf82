#include "sim/rover.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/settings.h"
#include "sim/sim_bus.h"

namespace contego::sim {
namespace {

constexpr uint16_t kGopigoAddr = 0x08;
constexpr uint16_t kLineFollowerAddr = 0x06;
constexpr double kWheelRadiusM = 0.0325;
constexpr int kTicksPerRev = 18;

// The vendor's hard-coded calibration and weights.
constexpr std::array<int, 5> kLineWhite = {767, 815, 859, 710, 700};
constexpr std::array<int, 5> kLineBlack = {1012, 1013, 1015, 1003, 1004};
constexpr std::array<int, 5> kLineWeights = {-100, -50, 0, 50, 100};
constexpr double kLineThreshold = 2500.0;

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kWheelBaseM = 0.117;
constexpr double sensor_ahead_m_ = 0.07;  // sensor bar ahead of the axle
constexpr double kSensorPitchM = 0.015;   // between neighbouring sensors
constexpr double kLineWidthM = 0.019;     // electrical tape
constexpr double kSensorFootprintM = 0.008;
constexpr double kOffLineM = 0.05;

constexpr uint8_t kSetLeftSpeed = 70;
constexpr uint8_t kSetRightSpeed = 71;
constexpr uint8_t kLeft = 97;
constexpr uint8_t kRight = 100;
constexpr uint8_t kBackward = 107;
constexpr uint8_t kIncreaseSpeed = 116;
constexpr uint8_t kStop = 120;

bool is_direction(uint8_t cmd) {
  switch (cmd) {
    case 97:
    case 98:
    case 100:
    case 105:
    case 107:
    case 110:
    case 115:
    case 119:
    case 120:
      return true;
    default:
      return false;
  }
}

// A motion frame of the victim task, as the library frames it: 01 cmd v1 v2 v3.
bool is_rover_frame(const TimedOp& op, const std::string& task) {
  return op.is_write(task, kGopigoAddr, 5);
}

// Control spoofing: the compromised loop turns a motor off (set_right_speed(0)
// and left(), which runs only the right wheel) or drives the wrong way.
class RoverSpoof : public Attack {
 public:
  RoverSpoof(AttackSpec spec, bool reverse) : Attack(std::move(spec)), reverse_(reverse) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    for (auto& op : ops) {
      if (!is_rover_frame(op, task)) continue;
      auto& b = op.op.bytes;
      if (!reverse_ && b[1] == kSetRightSpeed) {
        b[2] = 0;
        op.injected = true;
      } else if (is_direction(b[1])) {
        b[1] = reverse_ ? kBackward : kLeft;
        op.injected = true;
      }
    }
  }

 private:
  bool reverse_;
};

// DoS: a burst of increase_speed frames after the job's own frames.
class RoverDos : public Attack {
 public:
  explicit RoverDos(AttackSpec spec) : Attack(std::move(spec)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    uint64_t last = job.release_us;
    for (const auto& op : ops) last = std::max(last, op.at_us);
    const int64_t count = spec().param_int("count", 10);
    for (int64_t i = 0; i < count; ++i) {
      TimedOp op{last + 1000 * static_cast<uint64_t>(i + 1), task,
                 write_op(kGopigoAddr, {1, kIncreaseSpeed, 0, 0, 0}), true};
      ops.push_back(std::move(op));
    }
  }
};

// Availability attack: a spoofing thread of the follower sends stop() every
// `every_ms` through the job (`count` frames): stop is the safe command, so
// each one is safe, but together they keep the rover standing.
class RoverStopFlood : public Attack {
 public:
  explicit RoverStopFlood(AttackSpec spec) : Attack(std::move(spec)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    const auto every_us = static_cast<uint64_t>(spec().param_int("every_ms", 10)) * 1000;
    const int64_t count = spec().param_int("count", 20);
    for (int64_t i = 1; i <= count; ++i) {
      ops.push_back({job.release_us + every_us * static_cast<uint64_t>(i) - 500, task,
                     write_op(kGopigoAddr, {1, kStop, 0, 0, 0}), true});
    }
  }
};

// Replay: the job's motion frames are replaced by the ones the task sent
// `age_ms` earlier (a recorded, stale command sequence).
class RoverReplay : public Attack {
 public:
  explicit RoverReplay(AttackSpec spec) : Attack(std::move(spec)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    const uint64_t age = static_cast<uint64_t>(spec().param_int("age_ms", 3000)) * 1000;
    std::vector<std::pair<uint64_t, std::vector<uint8_t>>> mine;
    for (const auto& op : ops) {
      if (is_rover_frame(op, task)) mine.emplace_back(op.at_us - job.release_us, op.op.bytes);
    }
    history_[job.release_us] = mine;
    while (!history_.empty() && history_.begin()->first + age + 1'000'000 < job.release_us) {
      history_.erase(history_.begin());
    }
    if (!spec().active(job.release_us) || job.release_us < age) return;
    auto it = history_.upper_bound(job.release_us - age);
    if (it == history_.begin()) return;
    --it;
    const auto& old = it->second;
    size_t k = 0;
    for (auto& op : ops) {
      if (!is_rover_frame(op, task) || k >= old.size()) continue;
      op.op.bytes = old[k++].second;
      op.injected = true;
    }
  }

 private:
  std::map<uint64_t, std::vector<std::pair<uint64_t, std::vector<uint8_t>>>> history_;
};

// Unauthorised task: another program on the box stops the rover once per
// period, at a time the line follower is not writing.
class RoverIntruder : public Attack {
 public:
  explicit RoverIntruder(AttackSpec spec) : Attack(std::move(spec)) {
    auto it = this->spec().params.find("task");
    intruder_ = it == this->spec().params.end() ? "intruder" : it->second;
  }
  void apply(const Job& job, const std::string&, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    ops.push_back(
        {job.release_us + 150'000, intruder_, write_op(kGopigoAddr, {1, kStop, 0, 0, 0}), true});
  }

 private:
  std::string intruder_;
};

}  // namespace

double line_position(const std::array<uint16_t, 5>& raw) {
  double pos = 0.0;
  for (size_t i = 0; i < 5; ++i) {
    pos += (static_cast<double>(raw[i]) - kLineWhite[i]) * 100.0 /
           static_cast<double>(kLineBlack[i] - kLineWhite[i]) * kLineWeights[i];
  }
  return pos;
}

void LineFollowerController::release(const Job& job, Port& port, std::vector<TimedOp>& ops) {
  const uint64_t t = job.release_us;
  // Sensor group: request an analog read, then read ten bytes (C library form).
  port.write(o_.task, write_op(kLineFollowerAddr, {1, 3, 0, 0, 0}));
  auto reply = port.read(o_.task, read_op(kLineFollowerAddr, 10));
  std::array<uint16_t, 5> raw{};
  if (reply && reply->size() >= 10) {
    for (size_t i = 0; i < 5; ++i) {
      raw[i] = static_cast<uint16_t>(((*reply)[2 * i] << 8) | (*reply)[2 * i + 1]);
    }
    last_pos_ = line_position(raw);
  }
  uint8_t speed = 80;
  uint8_t dir = o_.fwd_opcode;
  if (last_pos_ < -kLineThreshold) {
    speed = 85;
    dir = kRight;
  } else if (last_pos_ > kLineThreshold) {
    speed = 125;
    dir = kLeft;
  }
  // set_speed(s): left frame, 5 ms, 100 ms, right frame, 5 ms; then the direction.
  ops.push_back({t + 2'000, o_.task, write_op(kGopigoAddr, {1, kSetLeftSpeed, speed, 0, 0})});
  ops.push_back({t + 107'000, o_.task, write_op(kGopigoAddr, {1, kSetRightSpeed, speed, 0, 0})});
  ops.push_back({t + 112'000, o_.task, write_op(kGopigoAddr, {1, dir, 0, 0, 0})});
}

RoverWorld::RoverWorld(const std::map<std::string, std::string>& settings, uint64_t seed)
    : World("rover", derive_seed(seed, 1)),
      controller_(LineFollowerController::Options{
          setting_string(settings, "task", "follower"),
          setting_duration_us(settings, "period", 200'000),
          static_cast<uint8_t>(setting_int(settings, "fwd_opcode", 105))}),
      gopigo_(add_device(std::make_shared<bus::GoPiGo2>(kGopigoAddr))),
      line_(add_device(std::make_shared<bus::LineFollower>(kLineFollowerAddr))) {
  set_controllers({&controller_});
  add_column("x_m", [this] { return x_; });
  add_column("y_m", [this] { return y_; });
  add_column("offset_cm", [this] { return line_offset(x_, y_) * 100.0; });
  add_column("left_cmd", [this] { return static_cast<double>(left_command()); });
  add_column("right_cmd", [this] { return static_cast<double>(right_command()); });
  add_column("distance_cm", [this] { return distance_cm(); });
  add_column("speed_cm_s", [this] { return speed_cm_s(); });
  add_column("line_position", [this] { return controller_.last_position(); });
  add_column("progress_cm", [this] { return progress_m_ * 100.0; });
  add_metric("distance", "cm", [this] { return distance_cm(); });
  add_metric("track_progress", "cm", [this] { return progress_m_ * 100.0; });
  add_metric("max_speed", "cm/s", [this] { return max_speed_; });
  add_metric("off_line_time", "s", [this] { return off_line_s_; });
  add_attack("spoof",
             [](const AttackSpec& spec) { return std::make_unique<RoverSpoof>(spec, false); });
  add_attack("wrong_direction",
             [](const AttackSpec& spec) { return std::make_unique<RoverSpoof>(spec, true); });
  add_attack("dos", [](const AttackSpec& spec) { return std::make_unique<RoverDos>(spec); });
  add_attack("replay", [](const AttackSpec& spec) { return std::make_unique<RoverReplay>(spec); });
  add_attack("stop_flood",
             [](const AttackSpec& spec) { return std::make_unique<RoverStopFlood>(spec); });
  add_attack("unauthorised",
             [](const AttackSpec& spec) { return std::make_unique<RoverIntruder>(spec); });
  straight_m_ = setting_double(settings, "straight", 2.0);
  radius_m_ = setting_double(settings, "radius", 1.0);
  speed_noise_ = setting_double(settings, "speed_noise", 0.03);
  sensor_noise_ = setting_double(settings, "sensor_noise", 6.0);
  max_rev_per_s_ = setting_double(settings, "max_rev_per_s", 1.4);
  motor_lag_s_ = setting_double(settings, "motor_lag", 0.08);
  sensor_ahead_m_ = setting_double(settings, "sensor_ahead", 0.07);
  x_ = 0.0;
  y_ = -radius_m_;
  heading_ = 0.0;
  update_sensor();
}

namespace {

// The sign a GoPiGo motion command gives one wheel's speed: 1 forward, -1
// backward, 0 stopped.
int wheel_sign(int motion, bool left) {
  switch (motion) {
    case 0x69:  // fwd
    case 0x77:  // fwd (PID)
      return 1;
    case 0x6B:
    case 0x73:
      return -1;
    case 0x64:  // right: the left wheel drives
    case 0x70:  // motor2 (direction not modelled: forward)
      return left ? 1 : 0;
    case 0x61:  // left: the right wheel drives
    case 0x6F:  // motor1
      return left ? 0 : 1;
    case 0x6E:  // right_rot
      return left ? 1 : -1;
    case 0x62:  // left_rot
      return left ? -1 : 1;
    default:  // stop
      return 0;
  }
}

}  // namespace

int RoverWorld::left_command() const {
  return gopigo_->left_speed() * wheel_sign(gopigo_->motion(), true);
}

int RoverWorld::right_command() const {
  return gopigo_->right_speed() * wheel_sign(gopigo_->motion(), false);
}

double RoverWorld::line_offset(double x, double y) const {
  const double half = straight_m_ / 2.0;
  const double cx = std::clamp(x, -half, half);
  return std::hypot(x - cx, y) - radius_m_;
}

double RoverWorld::track_position(double x, double y) const {
  const double half = straight_m_ / 2.0, r = radius_m_, pi = std::numbers::pi;
  const double start = half;  // the rover starts mid-way along the bottom straight
  double s = 0.0;
  if (x >= -half && x <= half) {
    s = y < 0 ? x + half : straight_m_ + pi * r + (half - x);
  } else if (x > half) {
    s = straight_m_ + r * (std::atan2(y, x - half) + pi / 2.0);
  } else {
    double a = std::atan2(y, x + half);
    if (a < 0) a += 2.0 * pi;
    s = 2.0 * straight_m_ + pi * r + r * (a - pi / 2.0);
  }
  const double lap = 2.0 * straight_m_ + 2.0 * pi * r;
  return std::fmod(s - start + lap, lap);
}

void RoverWorld::update_sensor() {
  std::array<uint16_t, 5> raw{};
  const double c = std::cos(heading_), s = std::sin(heading_);
  for (size_t i = 0; i < 5; ++i) {
    // Sensor 0 sits on the rover's right, sensor 4 on its left.
    const double lateral = (static_cast<double>(i) - 2.0) * kSensorPitchM;
    const double sx = x_ + sensor_ahead_m_ * c - lateral * s;
    const double sy = y_ + sensor_ahead_m_ * s + lateral * c;
    const double d = std::abs(line_offset(sx, sy));
    const double cover =
        std::clamp((kLineWidthM / 2 + kSensorFootprintM / 2 - d) / kSensorFootprintM, 0.0, 1.0);
    const double v =
        kLineWhite[i] + (kLineBlack[i] - kLineWhite[i]) * cover + noise_.gaussian(sensor_noise_);
    raw[i] = static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 1023L));
  }
  line_->set_values(raw);
}

void RoverWorld::step(uint64_t now_us, uint64_t dt_us) {
  const double dt = static_cast<double>(dt_us) * 1e-6;
  const double max_w = max_rev_per_s_ * kTwoPi;
  const double target_l = left_command() / 255.0 * max_w;
  const double target_r = right_command() / 255.0 * max_w;
  const double a = std::min(1.0, dt / motor_lag_s_);
  w_left_ += (target_l - w_left_) * a;
  w_right_ += (target_r - w_right_) * a;
  const double wl = w_left_ * (1.0 + noise_.gaussian(speed_noise_));
  const double wr = w_right_ * (1.0 + noise_.gaussian(speed_noise_));
  const double v = kWheelRadiusM * (wl + wr) / 2.0;
  const double omega = kWheelRadiusM * (wr - wl) / kWheelBaseM;
  x_ += v * std::cos(heading_) * dt;
  y_ += v * std::sin(heading_) * dt;
  heading_ = std::remainder(heading_ + omega * dt, kTwoPi);
  angle_left_ += std::abs(wl) * dt;
  angle_right_ += std::abs(wr) * dt;
  const auto tl = static_cast<uint64_t>(angle_left_ * kTicksPerRev / kTwoPi);
  const auto tr = static_cast<uint64_t>(angle_right_ * kTicksPerRev / kTwoPi);
  gopigo_->set_encoder(0, static_cast<uint16_t>(tl & 0xFFFF));
  gopigo_->set_encoder(1, static_cast<uint16_t>(tr & 0xFFFF));
  ticks_left_ = tl;
  ticks_right_ = tr;
  if (std::abs(line_offset(x_, y_)) > kOffLineM) off_line_s_ += dt;
  const double lap = 2.0 * straight_m_ + 2.0 * std::numbers::pi * radius_m_;
  const double s_now = track_position(x_, y_);
  double ds = s_now - last_s_;
  if (ds > lap / 2) ds -= lap;
  if (ds < -lap / 2) ds += lap;
  progress_m_ += ds;
  last_s_ = s_now;
  update_sensor();

  now_us_ = now_us;
  if (history_.empty() || now_us >= history_.back().first + 10'000) {
    history_.emplace_back(now_us, distance_cm());
    while (history_.size() > 1 && history_.front().first + 1'000'000 < now_us) {
      history_.pop_front();
    }
    if (history_.size() > 1 && now_us - history_.front().first >= 500'000) {
      const double speed = (history_.back().second - history_.front().second) /
                           (static_cast<double>(now_us - history_.front().first) * 1e-6);
      max_speed_ = std::max(max_speed_, speed);
    }
  }
}

double RoverWorld::distance_cm() const {
  const double per_tick = kTwoPi * kWheelRadiusM * 100.0 / kTicksPerRev;
  return static_cast<double>(ticks_left_ + ticks_right_) / 2.0 * per_tick;
}

double RoverWorld::speed_cm_s() const {
  if (history_.size() < 2 || history_.back().first <= history_.front().first) return 0.0;
  return (history_.back().second - history_.front().second) /
         (static_cast<double>(history_.back().first - history_.front().first) * 1e-6);
}

}  // namespace contego::sim
