#include "devices/model_profile.h"

#include <algorithm>
#include <fmt/format.h>

#include "devices/lower.h"

namespace contego::devices {
namespace {

bool same_geometry(const core::FieldRecord& a, const core::FieldRecord& b) {
  return a.offset == b.offset && a.nbytes == b.nbytes && a.shift == b.shift && a.width == b.width &&
         a.flags == b.flags;
}

// True if `p` lowered with any binding gives exactly the device's records.
bool matches(const ProfileSpec& p, const image::ImageModel& m, const core::DeviceRecord& d) {
  if (p.kind != d.profile || p.role != d.role || p.commands.size() != d.command_count ||
      p.frame_len != d.frame_len || p.prefix_len != d.prefix_len) {
    return false;
  }
  if (p.broadcast.has_value() != (d.broadcast != d.broadcast_target)) return false;
  if (p.gate.has_value() != (d.gated != 0)) return false;
  if ((p.role & core::kRoleSensor) != 0 &&
      (p.sample_len != d.sample_len || p.sample_request.size() != d.sample_request_len ||
       !std::equal(p.sample_request.begin(), p.sample_request.end(), d.sample_request))) {
    return false;
  }
  for (size_t k = 0; k < p.commands.size(); ++k) {
    const size_t id = d.command_first + k;
    if (id >= m.commands.size()) return false;
    const auto& rec = m.commands[id];
    const CommandSpec& c = p.commands[k];
    if (rec.name != c.name || rec.record.match != c.match || rec.record.group_len != c.group_len ||
        rec.record.repeat != c.repeat || rec.record.stride != c.stride ||
        rec.record.field_count != c.fields.size() || rec.record.command_class != c.command_class) {
      return false;
    }
    for (size_t f = 0; f < c.fields.size(); ++f) {
      const size_t fid = rec.record.field_first + f;
      if (fid >= m.fields.size() || m.fields[fid].name != c.fields[f].name ||
          !same_geometry(m.fields[fid].record, c.fields[f].geometry)) {
        return false;
      }
    }
  }
  return true;
}

FieldSpec field_from_record(const std::string& name, const core::FieldRecord& g) {
  FieldSpec f;
  f.name = name;
  f.geometry = g;
  f.geometry.name = 0;
  const uint32_t w = std::clamp<uint32_t>(g.width, 1, 32);
  if ((g.flags & core::kFieldSigned) != 0) {
    f.min = -(int64_t{1} << (w - 1));
    f.max = (int64_t{1} << (w - 1)) - 1;
  } else {
    f.min = 0;
    f.max = (int64_t{1} << w) - 1;
  }
  return f;
}

}  // namespace

Result<ProfileSpec> profile_from_model(const image::ImageModel& m, uint16_t device) {
  if (device >= m.devices.size()) {
    return make_error(
        fmt::format("no device {} in the image ({} devices)", device, m.devices.size()));
  }
  const core::DeviceRecord& d = m.devices[device].record;
  for (const ProfileSpec& p : builtin_profiles()) {
    if (matches(p, m, d)) return p;
  }
  ProfileSpec p;
  p.name = m.devices[device].name;
  p.kind = d.profile;
  p.role = d.role;
  p.frame_len = d.frame_len;
  p.prefix_len = d.prefix_len;
  p.auto_increment = d.auto_increment;
  p.ai_reg = d.ai_reg;
  p.ai_bit = d.ai_bit;
  for (const core::RegisterInitRecord& r : m.register_init) {
    if (r.device == device) p.power_on.push_back({r.reg, r.value});
  }
  for (const core::AliasRecord& a : m.aliases) {
    if (a.device == device) p.aliases.push_back({a.kind, a.addr});
  }
  for (uint32_t k = d.command_first; k < uint32_t{d.command_first} + d.command_count; ++k) {
    if (k >= m.commands.size()) return make_error("device command range outside the image");
    const auto& rec = m.commands[k];
    CommandSpec c;
    c.name = rec.name;
    c.group = std::to_string(rec.record.group);
    c.command_class = rec.record.command_class;
    c.match = rec.record.match;
    c.group_len = rec.record.group_len;
    c.repeat = rec.record.repeat;
    c.stride = rec.record.stride;
    for (uint32_t f = 0; f < rec.record.field_count; ++f) {
      const size_t fid = rec.record.field_first + f;
      if (fid >= m.fields.size()) return make_error("command field range outside the image");
      c.fields.push_back(field_from_record(m.fields[fid].name, m.fields[fid].record));
    }
    p.commands.push_back(std::move(c));
  }
  if (d.broadcast != d.broadcast_target && d.broadcast < p.commands.size() &&
      d.broadcast_target < p.commands.size()) {
    p.broadcast = BroadcastSpec{p.commands[d.broadcast].name, p.commands[d.broadcast_target].name};
  }
  if (d.gated != 0 && d.gated <= p.commands.size()) {
    p.gate = GateSpec{p.commands[d.gated - 1u].name, d.gate_bit};
  }
  p.sample_request.assign(d.sample_request,
                          d.sample_request + std::min<size_t>(d.sample_request_len, 8));
  p.sample_len = d.sample_len;
  const std::string prefix = m.devices[device].name + ".";
  for (const auto& s : m.signals) {
    if (s.record.kind != core::SignalKind::kRaw || s.record.device != device) {
      continue;
    }
    std::string name = s.name.rfind(prefix, 0) == 0 ? s.name.substr(prefix.size()) : s.name;
    FieldSpec f = field_from_record(name, s.record.field);
    f.min = std::max<int64_t>(f.min, s.record.valid_min);
    f.max = std::min<int64_t>(f.max, s.record.valid_max);
    if (f.min > f.max) f = field_from_record(name, s.record.field);
    bool duplicate = false;
    for (const FieldSpec& g : p.sample_fields) duplicate = duplicate || g.name == f.name;
    if (!duplicate) p.sample_fields.push_back(std::move(f));
  }
  return p;
}

}  // namespace contego::devices
