#include "sim/world.h"

#include <charconv>

namespace contego::sim {

BusOp write_op(uint16_t addr, std::vector<uint8_t> bytes) {
  BusOp op;
  op.kind = BusOp::Kind::kWrite;
  op.addr = addr;
  op.bytes = std::move(bytes);
  return op;
}

BusOp read_op(uint16_t addr, uint32_t len) {
  BusOp op;
  op.kind = BusOp::Kind::kRead;
  op.addr = addr;
  op.read_len = len;
  return op;
}

int64_t AttackSpec::param_int(const std::string& key, int64_t fallback) const {
  auto it = params.find(key);
  if (it == params.end()) return fallback;
  int64_t v = 0;
  const auto& s = it->second;
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) return fallback;
  return v;
}

void World::attach(bus::VirtualBus& bus) const {
  for (const auto& device : devices_) bus.attach(device);
}

std::vector<double> World::sample() const {
  std::vector<double> values;
  for (const auto& value : column_values_) values.push_back(value());
  return values;
}

std::vector<Metric> World::metrics() const {
  std::vector<Metric> out;
  for (const auto& m : metrics_) out.push_back({m.name, m.value(), m.unit});
  return out;
}

Result<std::unique_ptr<Attack>> World::make_attack(const AttackSpec& spec) const {
  std::string kinds;
  for (const auto& [kind, make] : attacks_) {
    if (kind == spec.kind) return make(spec);
    kinds += (kinds.empty() ? "" : ", ") + kind;
  }
  return make_error("unknown " + name_ + " attack '" + spec.kind + "' (expected " + kinds + ")");
}

}  // namespace contego::sim
