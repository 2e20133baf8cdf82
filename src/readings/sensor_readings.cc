#include "readings/sensor_readings.h"

#include <algorithm>

namespace contego::readings {
namespace {

void store(Reading& r, std::span<const uint8_t> data, uint32_t len, uint64_t taken_at_us) {
  r.len = std::min<uint32_t>({len, static_cast<uint32_t>(data.size()), core::kMaxSampleBytes});
  std::copy_n(data.begin(), r.len, r.bytes.begin());
  r.taken_at_us = taken_at_us;
}

bool fresh(const Reading& r, uint64_t now_us, uint64_t max_age_us) {
  if (r.len == 0) return false;
  return max_age_us == 0 || now_us <= r.taken_at_us || now_us - r.taken_at_us <= max_age_us;
}

}  // namespace

void SensorReadings::reset(uint32_t device_count) {
  sensors_.clear();
  sensors_.resize(device_count);
}

void SensorReadings::redescribe(uint16_t device, const core::DeviceRecord& rec) {
  if (device >= sensors_.size()) return;
  Sensor old = std::move(sensors_[device]);
  describe(device, rec);
  Sensor& s = sensors_[device];
  if (s.is_sensor && old.is_sensor && s.request == old.request && s.sample_len == old.sample_len) {
    s.request_pending = old.request_pending;
    s.newest = old.newest;
    s.by_task = std::move(old.by_task);
  }
}

void SensorReadings::describe(uint16_t device, const core::DeviceRecord& rec) {
  if (device >= sensors_.size()) return;
  Sensor& s = sensors_[device];
  s = Sensor{};
  if ((rec.role & core::kRoleSensor) == 0 || rec.sample_len == 0 ||
      rec.sample_len > core::kMaxSampleBytes) {
    return;
  }
  s.is_sensor = true;
  s.bus = rec.bus;
  s.addr = rec.addr;
  const uint8_t n = std::min<uint8_t>(rec.sample_request_len, sizeof(rec.sample_request));
  s.request.assign(rec.sample_request, rec.sample_request + n);
  s.sample_len = rec.sample_len;
  s.max_age_us = rec.max_sample_age_us;
  // A device without a request is read as it is until something writes to it.
  s.request_pending = s.request.empty();
}

SensorReadings::Sensor* SensorReadings::find(uint8_t bus, uint16_t addr) {
  for (Sensor& s : sensors_) {
    if (s.is_sensor && s.bus == bus && s.addr == addr) return &s;
  }
  return nullptr;
}

void SensorReadings::on_write(uint8_t bus, uint16_t addr, std::span<const uint8_t> bytes) {
  Sensor* s = find(bus, addr);
  if (s == nullptr) return;
  s->request_pending = std::equal(bytes.begin(), bytes.end(), s->request.begin(), s->request.end());
}

void SensorReadings::on_read(uint16_t task, uint8_t bus, uint16_t addr,
                             std::span<const uint8_t> pointer, std::span<const uint8_t> data,
                             uint64_t now_us) {
  Sensor* s = find(bus, addr);
  if (s == nullptr) return;
  if (!pointer.empty()) on_write(bus, addr, pointer);  // the pointer went first, on the same bus
  if (!s->request_pending || data.size() < s->sample_len) return;
  Reading r;
  store(r, data, s->sample_len, now_us);
  s->by_task[task] = r;
  if (r.taken_at_us >= s->newest.taken_at_us) s->newest = r;
}

void SensorReadings::on_sample(uint16_t device, std::span<const uint8_t> data,
                               uint64_t taken_at_us) {
  if (device >= sensors_.size() || !sensors_[device].is_sensor) return;
  Sensor& s = sensors_[device];
  s.request_pending = true;  // the sample's own request was the device's last write
  store(s.newest, data, s.sample_len, taken_at_us);
}

void SensorReadings::on_sample_failed(uint16_t device) {
  if (device >= sensors_.size()) return;
  Sensor& s = sensors_[device];
  s.newest = Reading{};
  s.by_task.clear();
}

void SensorReadings::forget_task(uint16_t task) {
  for (Sensor& s : sensors_) s.by_task.erase(task);
}

const Reading* SensorReadings::for_check(uint16_t task, uint16_t device, uint64_t now_us) const {
  if (device >= sensors_.size() || !sensors_[device].is_sensor) return nullptr;
  const Sensor& s = sensors_[device];
  // The state the controller saw, while it is fresh; else the newest known.
  auto own = s.by_task.find(task);
  if (own != s.by_task.end() && fresh(own->second, now_us, s.max_age_us)) return &own->second;
  return s.newest.len != 0 ? &s.newest : nullptr;
}

}  // namespace contego::readings
