// The sensor readings a command is judged against (docs/core.md, "Which
// reading a command is judged against").
//
// Every read of a sensor goes through the trusted side, which performs it on
// the bus: its bytes are as trustworthy as the trusted side's own samples.
// A controller acts on the reading it made, so a command of task T is judged
// against T's own latest reading of the sensor while that reading is no older
// than the device's `max_age`; otherwise against the newest reading anyone
// made (the trusted side's periodic sample or another task's read). The core
// still applies `max_age` to whatever it is given.
//
// A task's read counts as a reading only when it returns what the trusted
// side's own sample would: at least the sample's length, read right after the
// device's sample request (the request as the read's pointer bytes, or as the
// last write the device received from anyone).
//
// Shared by the monitor and the simulation's guard, so both judge the same.
// Not thread-safe: the owner serialises calls (the monitor under its mutex).
#ifndef CONTEGO_READINGS_SENSOR_READINGS_H_
#define CONTEGO_READINGS_SENSOR_READINGS_H_

#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "contego/core/image.h"
#include "contego/core/limits.h"

namespace contego::readings {

struct Reading {
  std::array<uint8_t, core::kMaxSampleBytes> bytes{};
  uint32_t len = 0;  // 0: none
  uint64_t taken_at_us = 0;
};

class SensorReadings {
 public:
  // Forgets everything, then `describe` each device of the image: only the
  // sensors' sampling fields are kept.
  void reset(uint32_t device_count);
  void describe(uint16_t device, const core::DeviceRecord& rec);
  // `describe` for a reloaded policy: a sensor sampled as before (the same
  // request and length) keeps its readings; its limits are the new record's.
  void redescribe(uint16_t device, const core::DeviceRecord& rec);

  // A write the bus performed on (bus, addr), from anyone: it moves a
  // sensor's register pointer / command state.
  void on_write(uint8_t bus, uint16_t addr, std::span<const uint8_t> bytes);
  // A read task `task` had performed on (bus, addr) at `now_us`: `pointer` are
  // the bytes written first in the same transfer (may be empty).
  void on_read(uint16_t task, uint8_t bus, uint16_t addr, std::span<const uint8_t> pointer,
               std::span<const uint8_t> data, uint64_t now_us);
  // The trusted side's own sample of `device` (it wrote the sample request
  // and read the sample), or its failure (the device's readings are dropped:
  // a sensor that stops answering makes its signals unavailable).
  void on_sample(uint16_t device, std::span<const uint8_t> data, uint64_t taken_at_us);
  void on_sample_failed(uint16_t device);
  // Drops the task's own readings (it exited; its id may be reused).
  void forget_task(uint16_t task);

  // The reading a command of `task` is judged against at `now_us` (nullptr:
  // none yet).
  const Reading* for_check(uint16_t task, uint16_t device, uint64_t now_us) const;

 private:
  struct Sensor {
    bool is_sensor = false;
    uint8_t bus = 0;
    uint16_t addr = 0;
    std::vector<uint8_t> request;
    uint32_t sample_len = 0;
    uint64_t max_age_us = 0;       // 0: no limit
    bool request_pending = false;  // the device's last write was its sample request
    Reading newest;
    std::map<uint16_t, Reading> by_task;
  };
  Sensor* find(uint8_t bus, uint16_t addr);

  std::vector<Sensor> sensors_;  // by device id
};

}  // namespace contego::readings

#endif  // CONTEGO_READINGS_SENSOR_READINGS_H_
