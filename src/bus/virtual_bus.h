// A virtual I2C bus hosting register-level device models in the trusted
// process, for tests and demos on machines without I2C. It answers like a
// Linux adapter: I2C_FUNCS of an I2C + full SMBus controller (PEC included,
// as i2c-core's emulation gives a plain one), and ENXIO for
// an address nobody acknowledges (what i2c-dev reports for a NACK on most
// adapters; i2cdetect treats any error as "no device"). set_funcs() makes it
// an adapter with other abilities (kI2cStubFuncs: SMBus-only, like Linux's
// i2c-stub): a transfer that adapter could not express is then refused with
// EOPNOTSUPP before it reaches any device, exactly as the real backend does.
#ifndef CONTEGO_BUS_VIRTUAL_BUS_H_
#define CONTEGO_BUS_VIRTUAL_BUS_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "base/mutex.h"
#include "bus/bus.h"

namespace contego::bus {

// A device on the virtual bus. Calls come with the bus lock held.
class DeviceModel {
 public:
  virtual ~DeviceModel() = default;
  // Does the device acknowledge `addr`? (primary address, all-call ...)
  virtual bool answers(uint16_t addr) const = 0;
  // Receives a general-call (address 0) write.
  virtual void general_call(std::span<const uint8_t> /*bytes*/) {}
  virtual void write(uint16_t addr, std::span<const uint8_t> bytes) = 0;
  // Fills `out` (a read transaction of out.size() bytes).
  virtual void read(uint16_t addr, std::span<uint8_t> out) = 0;
};

class VirtualBus final : public Bus {
 public:
  static constexpr uint64_t kFuncs = kFuncI2c | kFuncSmbusQuick | kFuncSmbusAllByteWord |
                                     kFuncSmbusReadBlock | kFuncSmbusWriteBlock |
                                     kFuncSmbusI2cBlock | kFuncSmbusBlockProcCall | kFuncSmbusPec;

  void attach(std::shared_ptr<DeviceModel> device);
  void set_funcs(uint64_t funcs) { funcs_.store(funcs); }
  uint64_t funcs() const override { return funcs_.load(); }
  int transfer(std::span<Msg> msgs) override;
  int quick(uint16_t addr, bool read) override;
  // Every bus operation seen (for tests: "nothing reached the bus").
  uint64_t operations() const;
  // Runs `fn` under the bus lock, so tests and plants can read a model
  // consistently while a monitor is serving.
  void with_lock(const std::function<void()>& fn) EXCLUDES(mu_);

 private:
  DeviceModel* find(uint16_t addr) const REQUIRES(mu_);
  mutable base::Mutex mu_;
  std::vector<std::shared_ptr<DeviceModel>> devices_ GUARDED_BY(mu_);
  uint64_t operations_ GUARDED_BY(mu_) = 0;
  std::atomic<uint64_t> funcs_{kFuncs};
};

// NXP PCA9685 16-channel PWM controller (register file per the datasheet).
class Pca9685 final : public DeviceModel {
 public:
  explicit Pca9685(uint16_t addr = 0x40);
  bool answers(uint16_t addr) const override;
  void general_call(std::span<const uint8_t> bytes) override;
  void write(uint16_t addr, std::span<const uint8_t> bytes) override;
  void read(uint16_t addr, std::span<uint8_t> out) override;

  uint8_t reg(uint8_t r) const { return regs_[r]; }
  uint16_t led_on(int channel) const;  // 13 bits: full-on flag (bit 12) + count
  uint16_t led_off(int channel) const;
  void reset();

 private:
  void store(uint8_t r, uint8_t value);
  uint16_t addr_;
  uint8_t pointer_ = 0;
  std::array<uint8_t, 256> regs_{};
};

// GoPiGo2 motor controller firmware: 4-byte command frames (the last four
// bytes of any write of >= 4 bytes), replies fetched as 1-byte reads.
class GoPiGo2 final : public DeviceModel {
 public:
  explicit GoPiGo2(uint16_t addr = 0x08) : addr_(addr) {}
  bool answers(uint16_t addr) const override { return addr == addr_; }
  void write(uint16_t addr, std::span<const uint8_t> bytes) override;
  void read(uint16_t addr, std::span<uint8_t> out) override;

  uint8_t left_speed() const { return speed2_; }   // set by command 70
  uint8_t right_speed() const { return speed1_; }  // set by command 71
  uint8_t motion() const { return motion_; }       // last motion opcode (0x78 = stopped)
  uint32_t frames() const { return frames_; }
  std::array<uint8_t, 4> last_frame() const { return last_; }
  void set_encoder(int motor, uint16_t ticks) { encoder_[motor & 1] = ticks; }

 private:
  uint16_t addr_;
  uint8_t speed1_ = 200, speed2_ = 200;
  uint8_t motion_ = 0x78;
  bool com_timeout_ = false;
  bool encoder_target_ = false;
  uint32_t frames_ = 0;
  std::array<uint8_t, 4> last_{};
  std::array<uint16_t, 2> encoder_{};
  std::vector<uint8_t> reply_;
};

// Dexter red line follower: write 01 03 00 00 00 (command 3), then read 10
// bytes = five big-endian 10-bit reflectance values from `source`.
class LineFollower final : public DeviceModel {
 public:
  using Source = std::function<std::array<uint16_t, 5>()>;
  explicit LineFollower(uint16_t addr = 0x06) : addr_(addr) {}
  bool answers(uint16_t addr) const override { return addr == addr_; }
  void write(uint16_t addr, std::span<const uint8_t> bytes) override;
  void read(uint16_t addr, std::span<uint8_t> out) override;
  void set_values(std::array<uint16_t, 5> values) { values_ = values; }
  void set_source(Source source) { source_ = std::move(source); }
  uint32_t requests() const { return requests_; }

 private:
  uint16_t addr_;
  std::array<uint16_t, 5> values_{512, 512, 512, 512, 512};
  Source source_;
  std::array<uint8_t, 10> reply_{};
  uint32_t requests_ = 0;
};

}  // namespace contego::bus

#endif  // CONTEGO_BUS_VIRTUAL_BUS_H_
