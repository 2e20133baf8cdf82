#include "sim/tank.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/settings.h"

namespace contego::sim {
namespace {

constexpr uint16_t kSensorAddr = 0x48;
constexpr uint16_t kBuzzerAddr = 0x20;
constexpr uint16_t kDisplayAddr = 0x3C;
constexpr int kLevelHigh = 800;  // mm
constexpr int kTempLow = 50;     // 0.1 degC
constexpr int kTempHigh = 400;

// False alarm: the monitor sounds the buzzer and raises the alert while the
// tank is normal (a nuisance that trains operators to ignore the alarm).
class FalseAlarm : public Attack {
 public:
  explicit FalseAlarm(AttackSpec spec) : Attack(std::move(spec)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    for (auto& op : ops) {
      const bool buzzer = op.is_write(task, kBuzzerAddr, 2) && op.op.bytes[0] == 0x01;
      const bool alert = op.is_write(task, kDisplayAddr, 2) && op.op.bytes[0] == 0x00;
      if (buzzer || alert) {
        op.op.bytes[1] = 1;
        op.injected = true;
      }
    }
  }
};

}  // namespace

void TankMonitor::release(const Job& job, Port& port, std::vector<TimedOp>& ops) {
  auto r = read_words(port, kSensorAddr, 0x00, 2);
  if (!r) return;
  const int level = (*r)[0];
  const int temp = static_cast<int16_t>((*r)[1]);
  const uint8_t on = (level > kLevelHigh || temp < kTempLow || temp > kTempHigh) ? 1 : 0;
  const uint64_t t = job.release_us;
  schedule(ops, t, kBuzzerAddr, {0x01, on});
  schedule(ops, t, kDisplayAddr, {0x00, on});
  // The displayed level, one register per write (the display does not auto-increment).
  schedule_word(ops, t, kDisplayAddr, 0x01, static_cast<uint16_t>(level));
}

TankWorld::TankWorld(const std::map<std::string, std::string>& settings, uint64_t seed)
    : World("tank", derive_seed(seed, 3)),
      monitor_(setting_string(settings, "task", "monitor"),
               setting_duration_us(settings, "period", 500'000)),
      sensor_(add_device(std::make_shared<RegisterFile>(kSensorAddr))),
      buzzer_(add_device(std::make_shared<RegisterFile>(kBuzzerAddr))),
      display_(add_device(std::make_shared<RegisterFile>(kDisplayAddr))) {
  set_controllers({&monitor_});
  add_attack("false_alarm",
             [](const AttackSpec& spec) { return std::make_unique<FalseAlarm>(spec); });
  add_column("level_mm", [this] { return level_mm_; });
  add_column("temp_c", [this] { return temp_dc_ / 10.0; });
  add_column("abnormal", [this] { return abnormal() ? 1.0 : 0.0; });
  add_column("buzzer", [this] { return static_cast<double>(buzzer_->reg(0x01)); });
  add_column("alert", [this] { return static_cast<double>(display_->reg(0x00)); });
  add_metric("buzzer_on_time", "s", [this] { return alarm_s_; });
  add_metric("false_alarm_time", "s", [this] { return false_alarm_s_; });
  add_metric("missed_alarm_time", "s", [this] { return missed_alarm_s_; });
  step(0, 0);
}

bool TankWorld::abnormal() const {
  return std::lround(level_mm_) > kLevelHigh || std::lround(temp_dc_) < kTempLow ||
         std::lround(temp_dc_) > kTempHigh;
}

void TankWorld::step(uint64_t now_us, uint64_t dt_us) {
  const double t = static_cast<double>(now_us) * 1e-6;
  const double dt = static_cast<double>(dt_us) * 1e-6;
  // Filling and draining in a one-minute cycle, high (above 800 mm) for
  // about a quarter of it; the temperature wanders around 20 degC.
  level_mm_ = 600.0 + 300.0 * std::sin(2.0 * std::numbers::pi * t / 60.0);
  temp_dc_ += noise_.gaussian(0.05) * std::sqrt(dt > 0 ? dt * 1000.0 : 0.0);
  temp_dc_ = std::clamp(temp_dc_, 150.0, 250.0);
  const auto level = static_cast<uint16_t>(std::lround(level_mm_));
  const auto temp = static_cast<int16_t>(std::lround(temp_dc_));
  sensor_->set_reg(0, static_cast<uint8_t>(level >> 8));
  sensor_->set_reg(1, static_cast<uint8_t>(level & 0xFF));
  sensor_->set_reg(2, static_cast<uint8_t>(static_cast<uint16_t>(temp) >> 8));
  sensor_->set_reg(3, static_cast<uint8_t>(static_cast<uint16_t>(temp) & 0xFF));
  const bool sounding = buzzer_->reg(0x01) != 0;
  if (sounding) alarm_s_ += dt;
  if (sounding && !abnormal()) false_alarm_s_ += dt;
  if (!sounding && abnormal()) missed_alarm_s_ += dt;
}

}  // namespace contego::sim
