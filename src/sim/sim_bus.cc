#include "sim/sim_bus.h"

namespace contego::sim {

int bus_write(bus::Bus& bus, uint16_t addr, std::span<const uint8_t> bytes) {
  std::vector<uint8_t> copy(bytes.begin(), bytes.end());
  bus::Msg m{addr, 0, static_cast<uint16_t>(copy.size()), copy.data()};
  return bus.transfer({&m, 1});
}

int bus_read(bus::Bus& bus, uint16_t addr, std::span<const uint8_t> pointer,
             std::span<uint8_t> out) {
  std::vector<uint8_t> ptr(pointer.begin(), pointer.end());
  bus::Msg msgs[2] = {{addr, 0, static_cast<uint16_t>(ptr.size()), ptr.data()},
                      {addr, 0x0001, static_cast<uint16_t>(out.size()), out.data()}};
  return ptr.empty() ? bus.transfer({&msgs[1], 1}) : bus.transfer(msgs);
}

void RegisterFile::write(uint16_t, std::span<const uint8_t> bytes) {
  if (bytes.empty()) return;
  pointer_ = bytes[0];
  uint8_t r = pointer_;
  for (size_t i = 1; i < bytes.size(); ++i) regs_[r++] = bytes[i];
}

void RegisterFile::read(uint16_t, std::span<uint8_t> out) {
  uint8_t r = pointer_;
  for (auto& b : out) b = regs_[r++];
}

PwmOutput pwm_output(const bus::Pca9685& chip, int channel) {
  const int base = 0x06 + 4 * channel;
  const bool sleeping = (chip.reg(0x00) & 0x10) != 0;
  const bool full_off = (chip.reg(static_cast<uint8_t>(base + 3)) & 0x10) != 0;
  const bool full_on = !full_off && (chip.reg(static_cast<uint8_t>(base + 1)) & 0x10) != 0;
  const int on = chip.reg(static_cast<uint8_t>(base)) |
                 ((chip.reg(static_cast<uint8_t>(base + 1)) & 0x0F) << 8);
  const int off = chip.reg(static_cast<uint8_t>(base + 2)) |
                  ((chip.reg(static_cast<uint8_t>(base + 3)) & 0x0F) << 8);
  PwmOutput o;
  o.full_on = full_on;
  o.ticks = full_on ? 4096 : static_cast<uint16_t>((off - on) & 0x0FFF);
  o.active = !sleeping && !full_off && o.ticks != 0;
  // f = 25 MHz / (4096 * (prescale + 1)): one tick lasts (prescale + 1) / 25 us.
  if (o.active) o.pulse_us = o.ticks * (chip.reg(0xFE) + 1.0) / 25.0;
  return o;
}

}  // namespace contego::sim
