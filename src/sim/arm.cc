#include "sim/arm.h"

#include <algorithm>
#include <cmath>

#include "sim/settings.h"
#include "sim/sim_bus.h"

namespace contego::sim {
namespace {

constexpr uint16_t kArmAddr = 0x40;
constexpr int kGripChannel = 5;
constexpr uint16_t kGripOpen = 420;
constexpr uint16_t kGripClose = 577;

// Joint pulses (60 Hz ticks) of the two poses; only the base turns.
constexpr std::array<uint16_t, 5> kPickPose = {250, 285, 200, 307, 375};
constexpr std::array<uint16_t, 5> kDropPose = {500, 285, 200, 307, 375};
constexpr double kPoseTolerance = 12.0;
constexpr double kServoMin = 150.0;  // tutRPi limits; beyond them the servo hits its stop
constexpr double kServoMax = 600.0;
constexpr double kTickUs60Hz = 1e6 / 60.0 / 4096.0;  // nominal tick at set_pwm_freq(60)

bool is_grip_write(const TimedOp& op, const std::string& task) {
  return op.is_write(task, kArmAddr, 2) && op.op.bytes[0] >= 0x06 + 4 * kGripChannel &&
         op.op.bytes[0] <= 0x09 + 4 * kGripChannel;
}

std::vector<TimedOp> at(uint64_t t, const std::string& task, const std::vector<BusOp>& ops,
                        bool injected) {
  std::vector<TimedOp> out;
  for (const auto& op : ops) out.push_back({t++, task, op, injected});  // 1 us apart
  return out;
}

// Control spoofing (Fig. 1): the gripper gets arbitrary high pulses.
class HighPulse : public Attack {
 public:
  HighPulse(AttackSpec spec, std::string victim) : Attack(std::move(spec), std::move(victim)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops,
             Noise& noise) override {
    if (!hits(job, task)) return;
    const auto lo = spec().param_int("min", 700);
    const auto hi = spec().param_int("max", 1400);
    const auto pulse = static_cast<uint16_t>(noise.uniform_int(lo, hi));
    bool rewrote = false;
    for (auto& op : ops) {
      if (!is_grip_write(op, task)) continue;
      op.rewrite_word(0x08 + 4 * kGripChannel, pulse);  // LEDn_OFF_L/H; ON stays
      op.injected = rewrote = true;
    }
    if (!rewrote) {  // jobs that do not touch the gripper get a pulse of their own
      auto extra = at(job.release_us + 200'000, task,
                      pca9685_set_pwm(kArmAddr, kGripChannel, 0, pulse), true);
      ops.insert(ops.end(), extra.begin(), extra.end());
    }
  }
};

// Configuration-register tampering: MODE1 sleep, PRE_SCALE, ALL_LED.
class ConfigTamper : public Attack {
 public:
  ConfigTamper(AttackSpec spec, std::string victim, std::vector<std::vector<uint8_t>> writes)
      : Attack(std::move(spec), std::move(victim)), writes_(std::move(writes)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!hits(job, task)) return;
    uint64_t t = job.release_us + 100'000;
    for (const auto& w : writes_) ops.push_back({t++, task, write_op(kArmAddr, w), true});
  }

 private:
  std::vector<std::vector<uint8_t>> writes_;
};

// Unauthorised task: another program opens the gripper while the arm moves.
class ArmIntruder : public Attack {
 public:
  ArmIntruder(AttackSpec spec, std::string victim) : Attack(std::move(spec), std::move(victim)) {
    auto it = this->spec().params.find("task");
    intruder_ = it == this->spec().params.end() ? "intruder" : it->second;
  }
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!hits(job, task)) return;
    auto extra = at(job.release_us + 250'000, intruder_,
                    pca9685_set_pwm(kArmAddr, kGripChannel, 0, kGripOpen), true);
    ops.insert(ops.end(), extra.begin(), extra.end());
  }

 private:
  std::string intruder_;
};

}  // namespace

std::vector<BusOp> pca9685_set_pwm(uint16_t addr, int channel, uint16_t on, uint16_t off) {
  const auto base = static_cast<uint8_t>(0x06 + 4 * channel);
  return {write_op(addr, {base, static_cast<uint8_t>(on & 0xFF)}),
          write_op(addr, {static_cast<uint8_t>(base + 1), static_cast<uint8_t>(on >> 8)}),
          write_op(addr, {static_cast<uint8_t>(base + 2), static_cast<uint8_t>(off & 0xFF)}),
          write_op(addr, {static_cast<uint8_t>(base + 3), static_cast<uint8_t>(off >> 8)})};
}

void ArmInitController::release(const Job& job, Port& port, std::vector<TimedOp>& ops) {
  if (job.index != 1) return;
  uint64_t t = job.release_us;
  auto add = [&](uint64_t when, const std::vector<BusOp>& bus_ops) {
    for (const auto& op : bus_ops) ops.push_back({when++, task(), op, false});
  };
  // PCA9685(): all channels off, MODE2 totem-pole, MODE1 all-call, wake up.
  add(t, {write_op(kArmAddr, {0xFA, 0}), write_op(kArmAddr, {0xFB, 0}),
          write_op(kArmAddr, {0xFC, 0}), write_op(kArmAddr, {0xFD, 0}),
          write_op(kArmAddr, {0x01, 0x04}), write_op(kArmAddr, {0x00, 0x01})});
  // set_pwm_freq(60) reads MODE1 first (at release: the chip still sleeps,
  // the library then writes what it read with SLEEP cleared).
  auto mode1 = read_register(port, kArmAddr, 0x00, 1);
  const uint8_t old = static_cast<uint8_t>((mode1 && !mode1->empty() ? (*mode1)[0] : 0x01) & ~0x10);
  add(t + 10'000, {write_op(kArmAddr, {0x00, old}),
                   write_op(kArmAddr, {0x00, static_cast<uint8_t>((old & 0x7F) | 0x10)}),
                   write_op(kArmAddr, {0xFE, 0x65}), write_op(kArmAddr, {0x00, old})});
  add(t + 20'000, {write_op(kArmAddr, {0x00, static_cast<uint8_t>(old | 0x80)})});
  // The drop (home) pose, one joint after the other.
  t += 30'000;
  for (int ch = 0; ch < 5; ++ch) {
    add(t, pca9685_set_pwm(kArmAddr, ch, 0, kDropPose[ch]));
    t += 1'000;
  }
}

void GripperController::release(const Job& job, Port&, std::vector<TimedOp>& ops) {
  auto add = [&](const std::vector<BusOp>& bus_ops) {
    uint64_t when = job.release_us;
    for (const auto& op : bus_ops) ops.push_back({when++, task(), op, false});
  };
  if (job.index == 1) {
    add(pca9685_set_pwm(kArmAddr, kGripChannel, 0, kGripOpen));
    return;
  }
  switch ((job.index - 2) % 4) {
    case 0:
      add(pca9685_set_pwm(kArmAddr, 0, 0, kPickPose[0]));
      break;
    case 1:
      add(pca9685_set_pwm(kArmAddr, kGripChannel, 0, kGripClose));
      break;
    case 2:
      add(pca9685_set_pwm(kArmAddr, 0, 0, kDropPose[0]));
      break;
    default:
      add(pca9685_set_pwm(kArmAddr, kGripChannel, 0, kGripOpen));
      break;
  }
}

ArmWorld::ArmWorld(const std::map<std::string, std::string>& settings, uint64_t seed)
    : World("arm", derive_seed(seed, 2)),
      init_(setting_string(settings, "init_task", "arm_init"), 10'000'000),
      gripper_(setting_string(settings, "task", "gripper"),
               setting_duration_us(settings, "period", 1'000'000), 50'000),
      pca_(add_device(std::make_shared<bus::Pca9685>(kArmAddr))),
      period_us_(setting_duration_us(settings, "period", 1'000'000)),
      // One object per four-job cycle, half a period before the base turns to pick it.
      next_arrival_us_(50'000 + period_us_ / 2) {
  set_controllers({&init_, &gripper_});
  add_column("grip_pulse", [this] { return effective_pulse(kGripChannel); });
  add_column("grip_state", [this] { return static_cast<double>(grip_); });
  add_column("base_pulse", [this] { return effective_pulse(0); });
  add_column("holding", [this] { return holding_ ? 1.0 : 0.0; });
  add_column("handled", [this] { return static_cast<double>(handled_); });
  add_column("lost", [this] { return static_cast<double>(lost_); });
  add_column("missed", [this] { return static_cast<double>(missed_); });
  add_metric("objects_handled", "", [this] { return static_cast<double>(handled_); });
  add_metric("objects_lost", "", [this] { return static_cast<double>(lost_); });
  add_metric("objects_missed", "", [this] { return static_cast<double>(missed_); });
  add_metric("spoofed_grip_pulses", "", [this] { return static_cast<double>(bad_pulses_); });
  add_metric("gripper_jammed_time", "s", [this] { return jammed_s_; });
  using Writes = std::vector<std::vector<uint8_t>>;
  auto tamper = [victim = gripper_.task()](Writes writes) {
    return [victim, writes](const AttackSpec& spec) {
      return std::make_unique<ConfigTamper>(spec, victim, writes);
    };
  };
  add_attack("high_pulse", [victim = gripper_.task()](const AttackSpec& spec) {
    return std::make_unique<HighPulse>(spec, victim);
  });
  add_attack("sleep", tamper({{0x00, 0x11}}));
  // Sleep, a 1526 Hz prescale, wake: the servo pulses lose their meaning.
  add_attack("prescale", tamper({{0x00, 0x11}, {0xFE, 0x03}, {0x00, 0x01}}));
  add_attack("all_led", tamper({{0xFB, 0x10}}));  // all full on
  add_attack("unauthorised", [victim = gripper_.task()](const AttackSpec& spec) {
    return std::make_unique<ArmIntruder>(spec, victim);
  });
}

double ArmWorld::effective_pulse(int channel) const {
  const auto o = pwm_output(*pca_, channel);
  if (!o.active) return 0.0;
  if (o.full_on) return -1.0;
  return o.pulse_us / kTickUs60Hz;
}

// Logs every write that sets the gripper's OFF_H (the last byte of a
// set_pwm) or ALL_LED_OFF_H, with the pulse the channel then holds: the
// paper's Fig. 1 plots these accesses in order.
void ArmWorld::on_write(uint64_t now_us, uint16_t addr, std::span<const uint8_t> bytes) {
  if ((addr != kArmAddr && addr != 0x70) || bytes.size() < 2) return;
  constexpr int kOffH = 0x09 + 4 * kGripChannel;
  const int first = bytes[0];
  const bool ai = (pca_->reg(0x00) & 0x20) != 0;
  const int last = ai ? first + static_cast<int>(bytes.size()) - 2 : first;
  const bool hits = (first <= kOffH && kOffH <= last) || (first <= 0xFD && 0xFD <= last);
  if (!hits) return;
  const auto o = pwm_output(*pca_, kGripChannel);
  double value = 0.0;
  if (o.full_on) {
    value = 4096.0;
  } else if ((pca_->reg(kOffH) & 0x10) == 0) {
    value = pca_->reg(kOffH - 1) | ((pca_->reg(kOffH) & 0x0F) << 8);
  }
  if (value != 0.0 && value != kGripOpen && value != kGripClose) ++bad_pulses_;
  events_.push_back({now_us, "grip_pulse", value});
}

void ArmWorld::step(uint64_t now_us, uint64_t dt_us) {
  now_us_ = now_us;
  const double p = effective_pulse(kGripChannel);
  Grip g = Grip::kBetween;
  if (p == 0.0) {
    g = Grip::kLimp;
  } else if (p < 0.0 || p < kServoMin * 0.95 || p > kServoMax * 1.05) {
    g = Grip::kJammed;  // driven against its end stop: it can neither pick nor drop
  } else if (p <= 460.0) {
    g = Grip::kOpen;
  } else if (p >= 540.0) {
    g = Grip::kClosed;
  }
  auto at_pose = [this](const std::array<uint16_t, 5>& pose) {
    for (int ch = 0; ch < 5; ++ch) {
      const double e = effective_pulse(ch);
      if (e <= 0.0 || std::abs(e - pose[ch]) > kPoseTolerance) return false;
    }
    return true;
  };
  if (now_us >= next_arrival_us_) {
    if (object_waiting_) ++missed_;  // the previous one rides past the station
    object_waiting_ = true;
    next_arrival_us_ += 4 * period_us_;
  }
  if (g != grip_) {
    if (g == Grip::kClosed && !holding_ && object_waiting_ && at_pose(kPickPose)) {
      holding_ = true;
      object_waiting_ = false;
    } else if ((g == Grip::kOpen || g == Grip::kLimp) && holding_) {
      if (g == Grip::kOpen && at_pose(kDropPose)) {
        ++handled_;
      } else {
        ++lost_;  // released or fallen away from the drop station
      }
      holding_ = false;
    }
    grip_ = g;
  }
  if (grip_ == Grip::kJammed) jammed_s_ += static_cast<double>(dt_us) * 1e-6;
}

}  // namespace contego::sim
