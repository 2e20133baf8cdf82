// What the tests' scripted deciders share: a device table built one device at
// a time, the host the monitor hands over, and verdicts written by hand.
#ifndef CONTEGO_MONITOR_TEST_FAKE_DECIDER_H_
#define CONTEGO_MONITOR_TEST_FAKE_DECIDER_H_

#include <cstdint>
#include <cstring>
#include <vector>

#include "monitor/decider.h"

namespace contego::monitor::testing {

class FakeDecider : public Decider {
 public:
  void set_host(const core::Host& host) override { host_ = host; }
  uint32_t device_count() const override { return static_cast<uint32_t>(devices_.size()); }
  const core::DeviceRecord& device(uint16_t id) const override { return devices_[id]; }

  // The latest sample the monitor hands to the core (through Host::read_sample).
  std::vector<uint8_t> sample(uint16_t device) {
    std::vector<uint8_t> buf(64);
    uint64_t at = 0;
    buf.resize(host_.read_sample(host_.context, device, buf.data(), 64, &at));
    return buf;
  }

 protected:
  // Declares the next device: `role` at `addr` on bus 1; returns it to fill in.
  core::DeviceRecord& add_device(uint8_t role, uint16_t addr) {
    core::DeviceRecord& d = devices_.emplace_back();
    d.role = role;
    d.bus = 1;
    d.addr = addr;
    return d;
  }
  // Appends `bytes` to the writes of *v.
  static void emit(core::Verdict* v, const std::vector<uint8_t>& bytes) {
    v->emit_len[v->emit_count++] = static_cast<uint16_t>(bytes.size());
    std::memcpy(v->emit_bytes + v->emit_bytes_used, bytes.data(), bytes.size());
    v->emit_bytes_used = static_cast<uint16_t>(v->emit_bytes_used + bytes.size());
  }

  core::Host host_{};
  std::vector<core::DeviceRecord> devices_;
};

}  // namespace contego::monitor::testing

#endif  // CONTEGO_MONITOR_TEST_FAKE_DECIDER_H_
