#include "devices/codec.h"

#include <fmt/format.h>

#include "devices/lower.h"

namespace contego::devices {
namespace {

uint64_t width_mask(uint8_t width) {
  return width >= 64 ? ~uint64_t{0} : (uint64_t{1} << width) - 1;
}

// ORs `value` into the bytes of `field` (the caller checked the range).
void place_field(const core::FieldRecord& g, int64_t value, std::span<uint8_t> bytes) {
  const uint64_t raw = (static_cast<uint64_t>(value) & width_mask(g.width)) << g.shift;
  for (uint32_t b = 0; b < g.nbytes; ++b) {
    const uint32_t pos =
        (g.flags & core::kFieldBigEndian) != 0 ? g.offset + g.nbytes - 1 - b : g.offset + b;
    bytes[pos] = static_cast<uint8_t>(bytes[pos] | ((raw >> (8 * b)) & 0xFF));
  }
}

// Fills `out` from named values: every name must be a field, every value in range.
Status place_fields(const std::string& where, const std::vector<FieldSpec>& specs,
                    std::span<const FieldValue> values, std::span<uint8_t> out) {
  for (const FieldValue& v : values) {
    const FieldSpec* spec = nullptr;
    for (const FieldSpec& f : specs) {
      if (f.name == v.name) spec = &f;
    }
    if (spec == nullptr) {
      std::string known;
      for (const FieldSpec& f : specs) known += (known.empty() ? "" : ", ") + f.name;
      return make_error(fmt::format("{} has no field '{}' (fields: {})", where, v.name,
                                    known.empty() ? "none" : known));
    }
    if (v.value < spec->min || v.value > spec->max) {
      return make_error(fmt::format("{} field '{}': value {} outside {}..{}", where, v.name,
                                    v.value, spec->min, spec->max));
    }
    place_field(spec->geometry, v.value, out);
  }
  return {};
}

}  // namespace

Result<int64_t> extract_field(const core::FieldRecord& g, std::span<const uint8_t> bytes) {
  if (g.nbytes < 1 || g.nbytes > 4 || g.width < 1 || g.width > 32 ||
      uint32_t{g.offset} + g.nbytes > bytes.size()) {
    return make_error(fmt::format("field at byte {} ({} bytes) outside {} bytes", g.offset,
                                  g.nbytes, bytes.size()));
  }
  uint64_t raw = 0;
  for (uint32_t b = 0; b < g.nbytes; ++b) {
    if ((g.flags & core::kFieldBigEndian) != 0) {
      raw = (raw << 8) | bytes[g.offset + b];
    } else {
      raw |= uint64_t{bytes[g.offset + b]} << (8 * b);
    }
  }
  raw = (raw >> g.shift) & width_mask(g.width);
  auto value = static_cast<int64_t>(raw);
  if ((g.flags & core::kFieldSigned) != 0 && (raw >> (g.width - 1)) != 0) {
    value -= int64_t{1} << g.width;
  }
  return value;
}

Result<std::vector<std::vector<uint8_t>>> encode_command(const ProfileSpec& profile,
                                                         std::string_view command,
                                                         std::span<const FieldValue> fields,
                                                         const EncodeOptions& options) {
  const CommandSpec* c = find_command(profile, command);
  if (c == nullptr) {
    return make_error(fmt::format("profile '{}' has no command '{}'", profile.name, command));
  }
  const std::string where = fmt::format("{}.{}", profile.name, c->name);
  std::vector<std::vector<uint8_t>> writes;
  if (profile.kind == core::Profile::kFrame) {
    std::vector<uint8_t> frame(profile.frame_len, 0);
    frame[0] = c->match;
    if (Status s = place_fields(where, c->fields, fields, frame); !s) return make_error(s.error());
    std::vector<uint8_t> write;
    if (options.with_prefix && profile.prefix_len == 1) write.push_back(options.prefix_byte);
    write.insert(write.end(), frame.begin(), frame.end());
    writes.push_back(std::move(write));
    return writes;
  }
  if (c->group_len == 0) {
    return make_error(fmt::format(
        "{}: a general-call command; write [0x{:02x}] to address 0x00 instead", where, c->match));
  }
  if (options.index >= c->repeat) {
    return make_error(
        fmt::format("{}: index {} outside 0..{}", where, options.index, c->repeat - 1));
  }
  std::vector<uint8_t> group(c->group_len, 0);
  if (Status s = place_fields(where, c->fields, fields, group); !s) return make_error(s.error());
  const uint32_t base = c->match + options.index * c->stride;
  if (options.per_register || c->group_len == 1) {
    for (uint32_t j = 0; j < c->group_len; ++j) {
      writes.push_back({static_cast<uint8_t>(base + j), group[j]});
    }
  } else {
    std::vector<uint8_t> write{static_cast<uint8_t>(base)};
    write.insert(write.end(), group.begin(), group.end());
    writes.push_back(std::move(write));
  }
  return writes;
}

Result<std::vector<uint8_t>> encode_sample(const ProfileSpec& profile,
                                           std::span<const FieldValue> fields) {
  std::vector<uint8_t> sample(profile.sample_len, 0);
  if (Status s = place_fields(fmt::format("{} sample", profile.name), profile.sample_fields, fields,
                              sample);
      !s) {
    return make_error(s.error());
  }
  return sample;
}

HostDecoder::HostDecoder(const ProfileSpec& profile) : profile_(&profile) {
  for (const RegisterValue& v : profile.power_on) shadow_[v.reg] = v.value;
}

Result<std::vector<DecodedCommand>> HostDecoder::write(std::span<const uint8_t> bytes) {
  if (profile_->kind == core::Profile::kFrame) return write_frame(bytes);
  return write_registers(bytes);
}

Result<std::vector<DecodedCommand>> HostDecoder::write_frame(std::span<const uint8_t> bytes) {
  const ProfileSpec& p = *profile_;
  if (bytes.size() == 1 && p.short_queries && p.frame_len != 1) return write_short_query(bytes[0]);
  if (bytes.size() != p.frame_len && bytes.size() != size_t{p.frame_len} + p.prefix_len) {
    return make_error(fmt::format(
        "{}: malformed write of {} bytes (frames are {}{})", p.name, bytes.size(), p.frame_len,
        p.prefix_len != 0 ? fmt::format(" or {} with prefix", p.frame_len + p.prefix_len) : ""));
  }
  // The device acts on the last frame_len bytes (the prefix is ignored).
  const std::span<const uint8_t> frame = bytes.subspan(bytes.size() - p.frame_len);
  for (const CommandSpec& c : p.commands) {
    if (c.match != frame[0]) continue;
    DecodedCommand d;
    d.command = &c;
    for (const FieldSpec& f : c.fields) {
      Result<int64_t> v = extract_field(f.geometry, frame);
      if (!v) return make_error(fmt::format("{}.{}: {}", p.name, c.name, v.error()));
      d.values.push_back(*v);
    }
    return std::vector<DecodedCommand>{std::move(d)};
  }
  return make_error(fmt::format("{}: unknown opcode {} (0x{:02x})", p.name, frame[0], frame[0]));
}

// A one-byte write naming a query is that query, its fields zero (as the
// core decodes it); any other single byte is malformed.
Result<std::vector<DecodedCommand>> HostDecoder::write_short_query(uint8_t opcode) {
  const ProfileSpec& p = *profile_;
  for (const CommandSpec& c : p.commands) {
    if (c.match != opcode) continue;
    if (c.command_class != core::CommandClass::kQuery) break;
    DecodedCommand d;
    d.command = &c;
    d.values.assign(c.fields.size(), 0);
    return std::vector<DecodedCommand>{std::move(d)};
  }
  return make_error(
      fmt::format("{}: malformed one-byte write 0x{:02x} (not a query)", p.name, opcode));
}

Result<std::vector<DecodedCommand>> HostDecoder::write_registers(std::span<const uint8_t> bytes) {
  const ProfileSpec& p = *profile_;
  if (bytes.empty()) return make_error(fmt::format("{}: empty write", p.name));
  // Auto-increment is decided once per write, from the shadow registers
  // before it: a write that sets MODE1.AI affects the next write.
  bool ai = p.auto_increment == core::AutoIncrement::kAlways;
  if (p.auto_increment == core::AutoIncrement::kBit) {
    ai = ((shadow_[p.ai_reg] >> p.ai_bit) & 1) != 0;
  }
  std::vector<DecodedCommand> out;
  for (size_t k = 1; k < bytes.size(); ++k) {
    const auto reg = static_cast<uint8_t>(ai ? bytes[0] + (k - 1) : bytes[0]);
    const CommandSpec* cmd = nullptr;
    uint32_t index = 0;
    uint32_t j = 0;
    for (const CommandSpec& c : p.commands) {
      for (uint32_t i = 0; i < c.repeat && cmd == nullptr; ++i) {
        const uint32_t start = c.match + i * c.stride;
        if (reg >= start && reg < start + c.group_len) {
          cmd = &c;
          index = i;
          j = reg - start;
        }
      }
      if (cmd != nullptr) break;
    }
    if (cmd == nullptr) {
      return make_error(
          fmt::format("{}: register 0x{:02x} is not covered by the profile", p.name, reg));
    }
    staged_[reg] = bytes[k];
    is_staged_[reg] = true;
    if (j + 1 < cmd->group_len) continue;  // staged until the group's last register
    const uint32_t start = cmd->match + index * cmd->stride;
    std::vector<uint8_t> group(cmd->group_len);
    for (uint32_t g = 0; g < cmd->group_len; ++g) {
      const auto r = static_cast<uint8_t>(start + g);
      group[g] = is_staged_[r] ? staged_[r] : shadow_[r];
    }
    DecodedCommand d;
    d.command = cmd;
    d.index = index;
    for (const FieldSpec& f : cmd->fields) {
      Result<int64_t> v = extract_field(f.geometry, group);
      if (!v) return make_error(fmt::format("{}.{}: {}", p.name, cmd->name, v.error()));
      d.values.push_back(*v);
    }
    for (uint32_t g = 0; g < cmd->group_len; ++g) {
      const auto r = static_cast<uint8_t>(start + g);
      shadow_[r] = group[g];
      is_staged_[r] = false;
    }
    out.push_back(std::move(d));
  }
  return out;
}

std::string describe(const DecodedCommand& d) {
  std::string s = d.command->name + "(";
  bool first = true;
  if (d.command->repeat > 1) {
    s += std::to_string(d.index);
    first = false;
  }
  for (size_t f = 0; f < d.command->fields.size() && f < d.values.size(); ++f) {
    s += fmt::format("{}{}={}", first ? "" : ", ", d.command->fields[f].name, d.values[f]);
    first = false;
  }
  return s + ")";
}

Result<std::string> describe(const ProfileSpec& profile, std::span<const uint8_t> bytes) {
  HostDecoder decoder(profile);
  Result<std::vector<DecodedCommand>> cmds = decoder.write(bytes);
  if (!cmds) return make_error(cmds.error());
  if (cmds->empty()) return std::string("(no command)");
  std::string s;
  for (const DecodedCommand& d : *cmds) s += (s.empty() ? "" : "; ") + describe(d);
  return s;
}

}  // namespace contego::devices
