// The simulator's use of the virtual I2C bus (src/bus): one-message helpers
// and the one device model the bus does not provide, a generic register file
// for the devices that policies declare as register maps (tank sensor,
// buzzer, pump, ...).
#ifndef CONTEGO_SIM_SIM_BUS_H_
#define CONTEGO_SIM_SIM_BUS_H_

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "bus/virtual_bus.h"

namespace contego::sim {

// One write message. 0 or an errno (ENXIO: nobody answers).
int bus_write(bus::Bus& bus, uint16_t addr, std::span<const uint8_t> bytes);
// A read of out.size() bytes, preceded by a write of `pointer` (register
// address) in the same combined transfer when `pointer` is not empty.
int bus_read(bus::Bus& bus, uint16_t addr, std::span<const uint8_t> pointer,
             std::span<uint8_t> out);

// A generic register file: a write [reg, data...] stores the data at reg,
// reg+1, ...; a read returns registers from the last written pointer on.
class RegisterFile final : public bus::DeviceModel {
 public:
  explicit RegisterFile(uint16_t addr) : addr_(addr) {}
  bool answers(uint16_t addr) const override { return addr == addr_; }
  void write(uint16_t addr, std::span<const uint8_t> bytes) override;
  void read(uint16_t addr, std::span<uint8_t> out) override;

  uint8_t reg(uint8_t r) const { return regs_[r]; }
  void set_reg(uint8_t r, uint8_t v) { regs_[r] = v; }

 private:
  uint16_t addr_;
  uint8_t pointer_ = 0;
  std::array<uint8_t, 256> regs_{};
};

// What a PCA9685 drives on one channel, from its registers.
struct PwmOutput {
  bool active = false;   // oscillator running, not full off, goes high at all
  bool full_on = false;  // constant high
  uint16_t ticks = 0;    // high time in ticks of the chip's period (off - on, mod 4096)
  double pulse_us = 0;   // high time in microseconds at the current PRE_SCALE
};
PwmOutput pwm_output(const bus::Pca9685& chip, int channel);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_SIM_BUS_H_
