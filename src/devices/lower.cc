#include "devices/lower.h"

#include <algorithm>
#include <array>
#include <fmt/format.h>
#include <set>

#include "contego/core/limits.h"

namespace contego::devices {
namespace {

// Checks one field's geometry against the bytes it may read (`span` bytes)
// and its declared range against what the geometry can represent.
Status validate_field(const std::string& where, const FieldSpec& f, uint32_t span) {
  const core::FieldRecord& g = f.geometry;
  if (f.name.empty()) return make_error(fmt::format("{}: a field has no name", where));
  const std::string at = fmt::format("{} field '{}'", where, f.name);
  if (g.nbytes < 1 || g.nbytes > 4) {
    return make_error(fmt::format("{}: nbytes {} outside 1..4", at, g.nbytes));
  }
  if (uint32_t{g.offset} + g.nbytes > span) {
    return make_error(fmt::format("{}: bytes {}..{} outside the {} bytes available", at, g.offset,
                                  g.offset + g.nbytes - 1, span));
  }
  if (g.width < 1 || g.width > 32 || g.shift >= 32 || g.shift + g.width > 8u * g.nbytes) {
    return make_error(fmt::format("{}: bits {}..{} do not fit in {} byte(s)", at, g.shift,
                                  g.shift + g.width - 1, g.nbytes));
  }
  if ((g.flags & ~(core::kFieldBigEndian | core::kFieldSigned)) != 0) {
    return make_error(fmt::format("{}: unknown flags 0x{:02x}", at, g.flags));
  }
  const bool is_signed = (g.flags & core::kFieldSigned) != 0;
  const int64_t lo = is_signed ? -(int64_t{1} << (g.width - 1)) : 0;
  const int64_t hi = is_signed ? (int64_t{1} << (g.width - 1)) - 1 : (int64_t{1} << g.width) - 1;
  if (f.min > f.max || f.min < lo || f.max > hi) {
    return make_error(fmt::format("{}: range {}..{} not representable in {} {} bit(s) ({}..{})", at,
                                  f.min, f.max, is_signed ? "signed" : "unsigned", g.width, lo,
                                  hi));
  }
  return {};
}

Status validate_fields(const std::string& where, const std::vector<FieldSpec>& fields,
                       uint32_t span) {
  std::set<std::string> names;
  for (const FieldSpec& f : fields) {
    if (Status s = validate_field(where, f, span); !s) return s;
    if (!names.insert(f.name).second) {
      return make_error(fmt::format("{}: field '{}' declared twice", where, f.name));
    }
  }
  return {};
}

}  // namespace

Status validate_profile(const ProfileSpec& p) {
  if (p.name.empty()) return make_error("device profile without a name");
  const std::string prof = fmt::format("profile '{}'", p.name);
  if (p.role == 0 || (p.role & ~(core::kRoleActuator | core::kRoleSensor)) != 0) {
    return make_error(fmt::format("{}: role bits 0x{:02x} invalid", prof, p.role));
  }
  const bool frame = p.kind == core::Profile::kFrame;
  if (!frame && p.kind != core::Profile::kRegisterMap) {
    return make_error(fmt::format("{}: unknown profile kind", prof));
  }
  if (frame) {
    if (p.prefix_len > 1) return make_error(fmt::format("{}: prefix_len must be 0 or 1", prof));
    if (p.frame_len < 1 || p.frame_len + p.prefix_len > core::kMaxWriteBytes) {
      return make_error(fmt::format("{}: frame_len {} invalid", prof, p.frame_len));
    }
  } else {
    if (p.frame_len != 0 || p.prefix_len != 0) {
      return make_error(fmt::format("{}: a register map has no frame length", prof));
    }
    if (p.auto_increment == core::AutoIncrement::kBit && p.ai_bit > 7) {
      return make_error(fmt::format("{}: auto-increment bit {} outside 0..7", prof, p.ai_bit));
    }
    if (p.auto_increment != core::AutoIncrement::kNever &&
        p.auto_increment != core::AutoIncrement::kAlways &&
        p.auto_increment != core::AutoIncrement::kBit) {
      return make_error(fmt::format("{}: unknown auto-increment mode", prof));
    }
  }
  if (p.commands.size() > core::kMaxCommandDefs) {
    return make_error(
        fmt::format("{}: {} commands, at most {}", prof, p.commands.size(), core::kMaxCommandDefs));
  }
  std::set<std::string> names;
  std::array<int, 256> owner;  // register-map coverage: command index or -1
  owner.fill(-1);
  std::set<uint8_t> opcodes;
  std::set<uint8_t> general_calls;  // register map: general-call command bytes
  for (size_t k = 0; k < p.commands.size(); ++k) {
    const CommandSpec& c = p.commands[k];
    if (c.name.empty()) return make_error(fmt::format("{}: command {} has no name", prof, k));
    const std::string where = fmt::format("{} command '{}'", prof, c.name);
    if (!names.insert(c.name).second) {
      return make_error(fmt::format("{}: declared twice", where));
    }
    if (c.group.empty()) return make_error(fmt::format("{}: no substitution group", where));
    if (c.command_class != core::CommandClass::kActuate &&
        c.command_class != core::CommandClass::kQuery &&
        c.command_class != core::CommandClass::kForbidden) {
      return make_error(fmt::format("{}: unknown command class", where));
    }
    if (c.fields.size() > core::kMaxFieldsPerCommand) {
      return make_error(fmt::format("{}: {} fields, at most {}", where, c.fields.size(),
                                    core::kMaxFieldsPerCommand));
    }
    if (frame) {
      if (c.group_len != 0 || c.repeat != 0 || c.stride != 0) {
        return make_error(fmt::format("{}: frame commands have no register group", where));
      }
      if (!opcodes.insert(c.match).second) {
        return make_error(fmt::format("{}: opcode {} used twice", where, c.match));
      }
      if (Status s = validate_fields(where, c.fields, p.frame_len); !s) return s;
    } else if (c.group_len == 0 && c.repeat == 0 && c.stride == 0) {
      // A general-call command: the byte [match] sent to the general-call address.
      const bool listens = std::any_of(p.aliases.begin(), p.aliases.end(), [](const AliasSpec& a) {
        return a.kind == core::AliasKind::kGeneralCall;
      });
      if (!listens || !c.fields.empty()) {
        return make_error(fmt::format(
            "{}: a general-call command needs a general-call alias and has no fields", where));
      }
      if (!general_calls.insert(c.match).second) {
        return make_error(fmt::format("{}: general-call byte {} used twice", where, c.match));
      }
    } else {
      if (c.group_len < 1 || c.repeat < 1 || (c.repeat > 1 && c.stride < c.group_len)) {
        return make_error(fmt::format("{}: group_len {} repeat {} stride {} invalid", where,
                                      c.group_len, c.repeat, c.stride));
      }
      for (uint32_t i = 0; i < c.repeat; ++i) {
        for (uint32_t j = 0; j < c.group_len; ++j) {
          const uint32_t reg = c.match + i * c.stride + j;
          if (reg > 0xFF) {
            return make_error(fmt::format("{}: register 0x{:x} beyond 0xff", where, reg));
          }
          if (owner[reg] >= 0) {
            return make_error(fmt::format("{}: register 0x{:02x} already belongs to '{}'", where,
                                          reg, p.commands[static_cast<size_t>(owner[reg])].name));
          }
          owner[reg] = static_cast<int>(k);
        }
      }
      if (Status s = validate_fields(where, c.fields, c.group_len); !s) return s;
    }
  }
  if (p.sample_request.size() > sizeof(core::DeviceRecord::sample_request)) {
    return make_error(fmt::format("{}: sample request of {} bytes, at most {}", prof,
                                  p.sample_request.size(),
                                  sizeof(core::DeviceRecord::sample_request)));
  }
  if (p.sample_len > core::kMaxSampleBytes) {
    return make_error(fmt::format("{}: sample of {} bytes, at most {}", prof, p.sample_len,
                                  core::kMaxSampleBytes));
  }
  if (Status s = validate_fields(prof + " sample", p.sample_fields, p.sample_len); !s) return s;
  if (!p.sample_fields.empty() && (p.role & core::kRoleSensor) == 0) {
    return make_error(fmt::format("{}: sample fields on a device that is no sensor", prof));
  }
  if (p.broadcast) {
    auto find = [&](const std::string& n) {
      return std::find_if(p.commands.begin(), p.commands.end(),
                          [&](const CommandSpec& c) { return c.name == n; });
    };
    const auto from = find(p.broadcast->from);
    const auto to = find(p.broadcast->to);
    if (p.kind != core::Profile::kRegisterMap || from == p.commands.end() ||
        to == p.commands.end() || from == to || from->repeat != 1 ||
        from->group_len != to->group_len) {
      return make_error(fmt::format(
          "{}: broadcast `{}` -> `{}` needs two register groups of one length, the first "
          "not repeated",
          prof, p.broadcast->from, p.broadcast->to));
    }
  }
  if (p.gate) {
    const auto g = std::find_if(p.commands.begin(), p.commands.end(),
                                [&](const CommandSpec& c) { return c.name == p.gate->command; });
    if (p.kind != core::Profile::kRegisterMap || g == p.commands.end() || g->repeat != 1 ||
        p.gate->bit > 7) {
      return make_error(fmt::format(
          "{}: gate `{}` (bit {}) needs a register group of the profile, not repeated, and a bit "
          "0..7 of its mode register",
          prof, p.gate->command, p.gate->bit));
    }
  }
  for (const AliasSpec& a : p.aliases) {
    if (a.kind == core::AliasKind::kAddress && (a.addr == 0 || a.addr > 0x7F)) {
      return make_error(fmt::format("{}: alias address 0x{:x} outside 0x01..0x7f", prof, a.addr));
    }
  }
  return {};
}

Result<uint16_t> append_device(image::ImageModel& model, const ProfileSpec& profile,
                               const DeviceBinding& binding) {
  if (Status s = validate_profile(profile); !s) return make_error(s.error());
  const std::string dev = fmt::format("device '{}' ({})", binding.name, profile.name);
  if (model.devices.size() >= core::kMaxDevices) {
    return make_error(fmt::format("{}: more than {} devices", dev, core::kMaxDevices));
  }
  size_t new_fields = 0;
  for (const CommandSpec& c : profile.commands) new_fields += c.fields.size();
  if (model.commands.size() + profile.commands.size() > core::kMaxCommandDefs) {
    return make_error(fmt::format("{}: its {} commands exceed the image limit of {} commands", dev,
                                  profile.commands.size(), core::kMaxCommandDefs));
  }
  if (model.fields.size() + new_fields > core::kMaxFieldDefs) {
    return make_error(fmt::format("{}: its {} fields exceed the image limit of {} fields", dev,
                                  new_fields, core::kMaxFieldDefs));
  }
  if (model.aliases.size() + profile.aliases.size() > core::kMaxAliases) {
    return make_error(fmt::format("{}: its {} aliases exceed the image limit of {}", dev,
                                  profile.aliases.size(), core::kMaxAliases));
  }
  if (binding.addr > (binding.ten_bit ? 0x3FF : 0x7F)) {
    return make_error(fmt::format("{}: address 0x{:x} out of range", dev, binding.addr));
  }
  if (binding.latch_mode != core::LatchMode::kOff &&
      (binding.latch_count < 1 || binding.latch_count > core::kMaxLatchCount)) {
    return make_error(fmt::format("{}: latch count {} outside 1..{}", dev, binding.latch_count,
                                  core::kMaxLatchCount));
  }

  const auto id = static_cast<uint16_t>(model.devices.size());
  image::Named<core::DeviceRecord> d;
  d.name = binding.name;
  core::DeviceRecord& r = d.record;
  r = core::DeviceRecord{};
  r.role = profile.role;
  r.profile = profile.kind;
  r.bus = binding.bus;
  r.ten_bit = binding.ten_bit ? 1 : 0;
  r.addr = binding.addr;
  r.command_first = static_cast<uint16_t>(model.commands.size());
  r.command_count = static_cast<uint16_t>(profile.commands.size());
  r.frame_len = profile.frame_len;
  r.prefix_len = profile.prefix_len;
  r.short_queries = profile.short_queries ? 1 : 0;
  if (profile.kind == core::Profile::kRegisterMap) {
    r.auto_increment = profile.auto_increment;
    r.ai_reg = profile.ai_reg;
    r.ai_bit = profile.ai_bit;
  }
  r.latch_mode = binding.latch_mode;
  if (binding.latch_mode != core::LatchMode::kOff) {
    r.latch_count = binding.latch_count;
    r.latch_window_us = binding.latch_window_us;
  }
  if ((profile.role & core::kRoleSensor) != 0) {
    r.sample_request_len = static_cast<uint8_t>(profile.sample_request.size());
    std::copy(profile.sample_request.begin(), profile.sample_request.end(), r.sample_request);
    r.sample_len = profile.sample_len;
    r.sample_period_us = binding.sample_period_us;
    r.max_sample_age_us = binding.max_sample_age_us;
  }
  r.safe_first = 0;
  r.safe_count = 0;
  if (profile.broadcast) {
    for (size_t k = 0; k < profile.commands.size(); ++k) {
      if (profile.commands[k].name == profile.broadcast->from)
        r.broadcast = static_cast<uint8_t>(k);
      if (profile.commands[k].name == profile.broadcast->to) {
        r.broadcast_target = static_cast<uint8_t>(k);
      }
    }
  }
  if (profile.gate) {
    for (size_t k = 0; k < profile.commands.size(); ++k) {
      if (profile.commands[k].name == profile.gate->command) r.gated = static_cast<uint8_t>(k + 1);
    }
    r.gate_bit = profile.gate->bit;
  }
  model.devices.push_back(std::move(d));

  for (const CommandSpec& c : profile.commands) {
    image::Named<core::CommandRecord> cr;
    cr.name = c.name;
    cr.record.device = id;
    cr.record.command_class = c.command_class;
    cr.record.field_count = static_cast<uint8_t>(c.fields.size());
    cr.record.field_first = static_cast<uint16_t>(model.fields.size());
    // Substitution groups are numbered per image: the first command of the
    // same device with the same group name gives its command id.
    uint16_t group = static_cast<uint16_t>(model.commands.size());
    for (uint16_t k = r.command_first; k < model.commands.size(); ++k) {
      if (profile.commands[k - r.command_first].group == c.group) {
        group = model.commands[k].record.group;
        break;
      }
    }
    cr.record.group = group;
    cr.record.match = c.match;
    cr.record.group_len = c.group_len;
    cr.record.repeat = c.repeat;
    cr.record.stride = c.stride;
    model.commands.push_back(std::move(cr));
    for (const FieldSpec& f : c.fields) {
      image::Named<core::FieldRecord> fr;
      fr.name = f.name;
      fr.record = f.geometry;
      fr.record.name = 0;
      model.fields.push_back(std::move(fr));
    }
  }
  for (const RegisterValue& v : profile.power_on) {
    model.register_init.push_back(core::RegisterInitRecord{id, v.reg, v.value});
  }
  for (const AliasSpec& a : profile.aliases) {
    core::AliasRecord ar{};
    ar.bus = binding.bus;
    ar.kind = a.kind;
    ar.addr = a.kind == core::AliasKind::kGeneralCall ? 0 : a.addr;
    ar.device = id;
    model.aliases.push_back(ar);
  }
  return id;
}

std::optional<uint16_t> find_command(const image::ImageModel& model, uint16_t device,
                                     std::string_view command) {
  if (device >= model.devices.size()) return std::nullopt;
  const core::DeviceRecord& d = model.devices[device].record;
  for (uint32_t k = d.command_first; k < uint32_t{d.command_first} + d.command_count; ++k) {
    if (k < model.commands.size() && model.commands[k].name == command) {
      return static_cast<uint16_t>(k);
    }
  }
  return std::nullopt;
}

const CommandSpec* find_command(const ProfileSpec& profile, std::string_view command) {
  for (const CommandSpec& c : profile.commands) {
    if (c.name == command) return &c;
  }
  return nullptr;
}

std::optional<uint8_t> find_field_slot(const CommandSpec& command, std::string_view field) {
  for (size_t f = 0; f < command.fields.size(); ++f) {
    if (command.fields[f].name == field) return static_cast<uint8_t>(f);
  }
  return std::nullopt;
}

std::optional<core::SignalRecord> make_raw_signal(const ProfileSpec& profile, uint16_t device,
                                                  std::string_view field) {
  for (const FieldSpec& f : profile.sample_fields) {
    if (f.name != field) continue;
    core::SignalRecord s{};
    s.kind = core::SignalKind::kRaw;
    s.device = device;
    s.field = f.geometry;
    s.field.name = 0;
    s.valid_min = static_cast<int32_t>(f.min);
    s.valid_max = static_cast<int32_t>(f.max);
    return s;
  }
  return std::nullopt;
}

FieldSpec make_int_field(std::string name, uint8_t offset, uint8_t nbytes, bool big_endian,
                         bool is_signed, int64_t min, int64_t max, std::string unit) {
  FieldSpec f;
  f.name = std::move(name);
  f.geometry = core::FieldRecord{};
  f.geometry.offset = offset;
  f.geometry.nbytes = nbytes;
  f.geometry.shift = 0;
  f.geometry.width = static_cast<uint8_t>(8 * nbytes);
  f.geometry.flags = static_cast<uint8_t>((big_endian ? core::kFieldBigEndian : 0) |
                                          (is_signed ? core::kFieldSigned : 0));
  f.min = min;
  f.max = max;
  f.unit = std::move(unit);
  return f;
}

Result<ProfileSpec> make_regmap_profile(const RegmapDecl& decl) {
  ProfileSpec p;
  p.name = decl.name;
  p.kind = core::Profile::kRegisterMap;
  p.role = decl.role;
  p.auto_increment =
      decl.auto_increment ? core::AutoIncrement::kAlways : core::AutoIncrement::kNever;
  p.power_on = decl.power_on;
  p.sample_request = decl.sample_request;
  p.sample_len = decl.sample_len;
  p.sample_fields = decl.sample_fields;
  p.doc = "generic register map declared in the policy";
  for (const RegisterDecl& reg : decl.registers) {
    if (reg.nbytes < 1 || reg.nbytes > 4) {
      return make_error(fmt::format("register '{}' at 0x{:02x}: {} bytes, expected 1..4", reg.name,
                                    reg.first, reg.nbytes));
    }
    CommandSpec c;
    c.name = reg.name;
    c.group = reg.name;
    c.command_class = reg.command_class;
    c.match = reg.first;
    c.group_len = reg.nbytes;
    c.repeat = 1;
    c.stride = reg.nbytes;
    c.fields.push_back(make_int_field("value", 0, reg.nbytes, reg.big_endian, reg.is_signed,
                                      reg.min, reg.max, reg.unit));
    c.doc = fmt::format("register 0x{:02x}", reg.first);
    p.commands.push_back(std::move(c));
  }
  for (const RegisterRange& range : decl.forbidden) {
    if (range.last < range.first) {
      return make_error(
          fmt::format("forbidden range 0x{:02x}..0x{:02x} is empty", range.first, range.last));
    }
    // repeat is 8 bits: a range of 256 registers needs two commands.
    uint32_t first = range.first;
    while (first <= range.last) {
      const uint32_t count = std::min<uint32_t>(range.last - first + 1, 255);
      CommandSpec c;
      c.name = fmt::format("forbid_0x{:02x}", first);
      c.group = c.name;
      c.command_class = core::CommandClass::kForbidden;
      c.match = static_cast<uint8_t>(first);
      c.group_len = 1;
      c.repeat = static_cast<uint8_t>(count);
      c.stride = 1;
      c.doc = fmt::format("registers 0x{:02x}..0x{:02x}: never written", first, first + count - 1);
      p.commands.push_back(std::move(c));
      first += count;
    }
  }
  if (Status s = validate_profile(p); !s) return make_error(s.error());
  return p;
}

}  // namespace contego::devices
