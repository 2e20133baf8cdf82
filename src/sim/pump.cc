#include "sim/pump.h"

#include <algorithm>
#include <cmath>

#include "sim/settings.h"

namespace contego::sim {
namespace {

constexpr uint16_t kPumpAddr = 0x50;
constexpr uint16_t kEncoderAddr = 0x51;
constexpr uint16_t kScreenAddr = 0x3D;

// Over-dose: the task drives the motor at `rate` uL/h whatever the encoder says.
class Overdose : public Attack {
 public:
  explicit Overdose(AttackSpec spec) : Attack(std::move(spec)) {}
  void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops, Noise&) override {
    if (!spec().active(job.release_us)) return;
    const auto rate = static_cast<uint16_t>(spec().param_int("rate", 1000));
    for (auto& op : ops) {
      if (!op.is_write(task, kPumpAddr, 2)) continue;
      op.rewrite_word(0x01, rate);
      op.injected = true;
    }
  }
};

}  // namespace

void InfusionController::release(const Job& job, Port& port, std::vector<TimedOp>& ops) {
  auto r = read_words(port, kEncoderAddr, 0x00, 1);
  if (!r) return;
  const uint16_t infused = (*r)[0];
  const uint16_t rate = infused < dose_ ? static_cast<uint16_t>(rate_) : 0;
  const uint64_t t = job.release_us;
  if (job.index == 1) schedule(ops, t, kPumpAddr, {0x03, 0});  // infuse
  // Rate (u16le) and the displayed volume, one register per write.
  schedule_word(ops, t, kPumpAddr, 0x01, rate);
  schedule_word(ops, t, kScreenAddr, 0x00, infused);
}

PumpWorld::PumpWorld(const std::map<std::string, std::string>& settings, uint64_t seed)
    : World("pump", derive_seed(seed, 4)),
      infusion_(setting_string(settings, "task", "infusion"),
                setting_duration_us(settings, "period", 60'000'000),
                static_cast<int>(setting_int(settings, "rate", 200)),
                static_cast<int>(setting_int(settings, "dose", 5000))),
      pump_(add_device(std::make_shared<RegisterFile>(kPumpAddr))),
      encoder_(add_device(std::make_shared<RegisterFile>(kEncoderAddr))),
      screen_(add_device(std::make_shared<RegisterFile>(kScreenAddr))),
      dose_(static_cast<int>(setting_int(settings, "dose", 5000))) {
  set_controllers({&infusion_});
  add_column("delivered_ul", [this] { return delivered_ul_; });
  add_column("rate_ul_h", [this] { return static_cast<double>(rate()); });
  add_column("screen_ul", [this] {
    return static_cast<double>(screen_->reg(0x00) | (screen_->reg(0x01) << 8));
  });
  add_metric("dose_delivered", "uL", [this] { return delivered_ul_; });
  add_metric("overdose", "uL", [this] { return std::max(0.0, delivered_ul_ - dose_); });
  add_metric("max_rate", "uL/h", [this] { return max_rate_; });
  add_metric("dose_reached_at", "h",
             [this] { return dose_reached_s_ < 0 ? -1.0 : dose_reached_s_ / 3600.0; });
  add_attack("overdose", [](const AttackSpec& spec) { return std::make_unique<Overdose>(spec); });
}

int PumpWorld::rate() const { return pump_->reg(0x01) | (pump_->reg(0x02) << 8); }

void PumpWorld::step(uint64_t now_us, uint64_t dt_us) {
  const double dt_h = static_cast<double>(dt_us) / 3600e6;
  const double flow = rate() * dt_h * (1.0 + noise_.gaussian(0.01));
  const bool withdraw = pump_->reg(0x03) != 0;
  delivered_ul_ = std::max(0.0, delivered_ul_ + (withdraw ? -flow : flow));
  max_rate_ = std::max(max_rate_, static_cast<double>(rate()));
  if (dose_reached_s_ < 0 && delivered_ul_ >= dose_) {
    dose_reached_s_ = static_cast<double>(now_us) * 1e-6;
  }
  const auto counted = static_cast<uint16_t>(std::min(60000.0, std::floor(delivered_ul_)));
  encoder_->set_reg(0, static_cast<uint8_t>(counted >> 8));
  encoder_->set_reg(1, static_cast<uint8_t>(counted & 0xFF));
}

}  // namespace contego::sim
