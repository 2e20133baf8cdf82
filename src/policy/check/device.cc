#include <algorithm>

#include "policy/check/context.h"

namespace contego::policy::check_internal {

namespace {

// Builds a generic register-map profile from a `regmap` declaration.
struct RegType {
  uint8_t nbytes;
  bool big_endian;
  bool is_signed;
};
std::optional<RegType> reg_type(const std::string& name) {
  if (name == "u8") return RegType{1, false, false};
  if (name == "s8") return RegType{1, false, true};
  if (name == "u16le") return RegType{2, false, false};
  if (name == "u16be") return RegType{2, true, false};
  if (name == "s16le") return RegType{2, false, true};
  if (name == "s16be") return RegType{2, true, true};
  if (name == "u32le") return RegType{4, false, false};
  if (name == "u32be") return RegType{4, true, false};
  return std::nullopt;
}

// A field of `type` at byte `offset`, spanning the type's whole range.
devices::FieldSpec typed_field(std::string name, uint8_t offset, const RegType& type) {
  devices::FieldSpec f;
  f.geometry = core::FieldRecord{};
  f.name = std::move(name);
  f.geometry.offset = offset;
  f.geometry.nbytes = type.nbytes;
  f.geometry.width = static_cast<uint8_t>(type.nbytes * 8);
  f.geometry.flags = static_cast<uint8_t>((type.big_endian ? core::kFieldBigEndian : 0) |
                                          (type.is_signed ? core::kFieldSigned : 0));
  const int bits = type.nbytes * 8;
  f.min = type.is_signed ? -(int64_t{1} << (bits - 1)) : 0;
  f.max = type.is_signed ? (int64_t{1} << (bits - 1)) - 1 : (int64_t{1} << bits) - 1;
  return f;
}

}  // namespace

void Sema::declare_device(const ast::DeviceDecl& d) {
  Device dev;
  dev.name = d.name.name;
  dev.span = d.name.span;
  bool ok = true;
  if (d.profile.name == "regmap") {
    ok = build_regmap(d, dev.profile);
  } else if (const devices::ProfileSpec* p = profiles_(d.profile.name)) {
    dev.profile = *p;
    if (!d.registers.empty() || !d.values.empty() || !d.forbid.empty() || d.auto_increment ||
        d.sample_request) {
      diags_.emit(DiagKind::kUnknownDeviceSetting,
                  d.registers.empty() ? d.span : d.registers[0].span, "register map declarations",
                  "them only on a `regmap` device; `" + d.profile.name + "` is built in");
    }
  } else {
    diags_.emit(DiagKind::kUnknownProfile, d.profile.span, d.profile.name,
                "`gopigo2`, `line_follower`, `pca9685` or `regmap`");
    ok = false;
  }
  dev.role = dev.profile.role;
  if (auto bus = const_value(*d.bus, Type::kInt, "the bus number")) {
    if (*bus < 0 || *bus > 255) {
      diags_.emit(DiagKind::kBadBus, d.bus_span, fmt::format("i2c-{}", *bus));
    } else {
      dev.bus = static_cast<uint8_t>(*bus);
    }
  }
  if (auto addr = const_value(*d.address, Type::kInt, "the I2C address")) {
    if (*addr < 1 || *addr > 0x7F) {
      diags_.emit(DiagKind::kBadAddress, d.address->span, fmt::format("{:#x}", *addr));
    } else {
      dev.addr = static_cast<uint16_t>(*addr);
      for (const Device& other : out_.devices) {
        if (other.bus == dev.bus && other.addr == dev.addr) {
          diags_.emit(DiagKind::kAddressInUse, d.address->span, dev.name, dev.bus,
                      fmt::format("{:#04x}", dev.addr), other.name);
          diags_.note(DiagKind::kPreviousDeclaration, other.span, other.name);
        }
      }
    }
  }
  if (d.sample_period) {
    if (!(dev.role & core::kRoleSensor)) {
      diags_.emit(DiagKind::kNotASensor, d.sample_period->span, dev.name, "`sample`");
    }
    dev.sample_period_us = duration_us(*d.sample_period, "`sample`");
  } else if (dev.role & core::kRoleSensor) {
    dev.sample_period_us = 10000;  // documented default: 10ms
  }
  if (d.max_age) {
    dev.max_age_us = duration_us(*d.max_age, "`max_age`");
    dev.max_age_declared = true;
  }
  if (d.latch_count) {
    if (auto k = int_in(*d.latch_count, "the latch count", 1, core::kMaxLatchCount)) {
      dev.latch_count = static_cast<uint8_t>(*k);
    }
    dev.latch_window_us = duration_us(*d.latch_window, "the latch window");
    dev.latch_unrepaired = d.latch_unrepaired;
    if (!(dev.role & core::kRoleActuator)) {
      diags_.emit(DiagKind::kNotAnActuator, d.latch_span, dev.name, "`latch`");
    }
  }
  if (!declare(dev.name, SymKind::kDevice, out_.devices.size(), d.name.span)) return;
  if (!ok) dev.profile.role = dev.role = core::kRoleActuator | core::kRoleSensor;
  dev_ok_.push_back(ok);
  out_.devices.push_back(std::move(dev));
}

bool Sema::build_regmap(const ast::DeviceDecl& d, devices::ProfileSpec& p) {
  p.name = "regmap";
  p.kind = core::Profile::kRegisterMap;
  p.role = 0;
  p.auto_increment = d.auto_increment ? core::AutoIncrement::kAlways : core::AutoIncrement::kNever;
  bool ok = true;
  std::vector<std::pair<int64_t, int64_t>> used;  // register ranges
  auto overlaps = [&](int64_t a, int64_t b, Span at) {
    for (auto [x, y] : used) {
      if (a <= y && x <= b) {
        diags_.emit(
            DiagKind::kBadRegister, at,
            fmt::format("registers {:#04x}..{:#04x} overlap a register declared above", a, b),
            "each register in one declaration");
        ok = false;
        return true;
      }
    }
    used.emplace_back(a, b);
    return false;
  };
  for (const auto& r : d.registers) {
    auto first = int_in(*r.first, "the register", 0, 255);
    auto last = r.last ? int_in(*r.last, "the register", 0, 255) : first;
    auto type = reg_type(r.type.name);
    if (!type) {
      diags_.emit(DiagKind::kBadRegister, r.type.span,
                  "unknown register type `" + r.type.name + "`",
                  "`u8`, `s8`, `u16le`, `u16be`, `s16le`, `s16be`, `u32le` or `u32be`");
      ok = false;
      continue;
    }
    if (!first || !last) {
      ok = false;
      continue;
    }
    if (!r.last) last = *first + type->nbytes - 1;  // `register 0x01 x : u16le`
    if (*last - *first + 1 != type->nbytes || *last > 255) {
      diags_.emit(DiagKind::kBadRegister, r.span,
                  fmt::format("`{}` spans {} registers but `{}` has {} bytes", r.name.name,
                              *last - *first + 1, r.type.name, type->nbytes),
                  "one register per byte of the type");
      ok = false;
      continue;
    }
    if (overlaps(*first, *last, r.span)) continue;
    devices::CommandSpec c;
    c.name = r.name.name;
    c.group = r.name.name;
    c.command_class = r.query ? core::CommandClass::kQuery : core::CommandClass::kActuate;
    c.match = static_cast<uint8_t>(*first);
    c.group_len = type->nbytes;
    c.repeat = 1;
    c.stride = 0;
    devices::FieldSpec f = typed_field("value", 0, *type);
    if (r.range) range_bounds(*r.range, f.min, f.max);
    c.fields.push_back(f);
    p.commands.push_back(std::move(c));
    p.role |= core::kRoleActuator;
  }
  for (size_t i = 0; i < d.forbid.size(); ++i) {
    auto first = int_in(*d.forbid[i].first, "the register", 0, 255);
    auto last = d.forbid[i].second ? int_in(*d.forbid[i].second, "the register", 0, 255) : first;
    if (!first || !last) {
      ok = false;
      continue;
    }
    if (*last < *first) {
      diags_.emit(DiagKind::kEmptyRange, d.forbid_spans[i], *first, *last);
      ok = false;
      continue;
    }
    if (overlaps(*first, *last, d.forbid_spans[i])) continue;
    devices::CommandSpec c;
    c.name = fmt::format("forbidden_{:02x}", *first);
    c.group = c.name;
    c.command_class = core::CommandClass::kForbidden;
    c.match = static_cast<uint8_t>(*first);
    c.group_len = static_cast<uint8_t>(*last - *first + 1);
    c.repeat = 1;
    p.commands.push_back(std::move(c));
  }
  if (d.sample_request || !d.values.empty()) {
    p.role |= core::kRoleSensor;
    if (d.sample_request) {
      if (auto bytes = const_list(*d.sample_request, "the sample request")) {
        if (bytes->size() > 8) {
          diags_.emit(DiagKind::kBadRegister, d.sample_request->span,
                      fmt::format("the sample request has {} bytes", bytes->size()), "at most 8");
          ok = false;
        }
        for (int64_t b : *bytes) p.sample_request.push_back(static_cast<uint8_t>(b & 0xFF));
      }
      if (auto len = int_in(*d.sample_length, "the sample length", 1, core::kMaxSampleBytes)) {
        p.sample_len = static_cast<uint8_t>(*len);
      }
    } else {
      diags_.emit(DiagKind::kMissingProperty, d.name.span, "sensor", d.name.name, "read",
                  "`read [REGISTER] length N` before its values");
      ok = false;
    }
    for (const auto& v : d.values) {
      auto type = reg_type(v.type.name);
      auto off = int_in(*v.offset, "the value offset", 0, core::kMaxSampleBytes - 1);
      if (!type) {
        diags_.emit(DiagKind::kBadRegister, v.type.span, "unknown value type `" + v.type.name + "`",
                    "`u8`, `s8`, `u16le`, `u16be`, `s16le`, `s16be`, `u32le` or `u32be`");
        ok = false;
        continue;
      }
      if (!off) continue;
      if (p.sample_len && *off + type->nbytes > p.sample_len) {
        diags_.emit(DiagKind::kBadRegister, v.span,
                    fmt::format("`{}` ends at byte {} of a {}-byte sample", v.name.name,
                                *off + type->nbytes, p.sample_len),
                    "values inside the sample");
        ok = false;
        continue;
      }
      devices::FieldSpec f = typed_field(v.name.name, static_cast<uint8_t>(*off), *type);
      if (v.range) range_bounds(*v.range, f.min, f.max);
      p.sample_fields.push_back(f);
    }
  }
  if (p.role == 0) p.role = core::kRoleActuator;
  return ok;
}

void Sema::range_bounds(const ast::Expr& r, int64_t& lo, int64_t& hi) {
  if (r.kind != ExprKind::kRange) {
    diags_.emit(DiagKind::kTypeMismatch, r.span, "`range`", "not a range",
                "a range such as `0..100`");
    return;
  }
  auto a = const_value(*r.kids[0], Type::kInt, "the range's low end");
  auto b = const_value(*r.kids[1], Type::kInt, "the range's high end");
  if (!a || !b) return;
  if (*a > *b) {
    diags_.emit(DiagKind::kEmptyRange, r.span, *a, *b);
    return;
  }
  if (*a < lo || *b > hi) {
    diags_.emit(DiagKind::kValueOutOfRange, r.span, "range", fmt::format("{}..{}", *a, *b),
                "the type", lo, hi);
    return;
  }
  lo = *a;
  hi = *b;
}

void Sema::resolve_safe_state(const ast::DeviceDecl& d) {
  const Sym* sym = lookup(d.name.name);
  if (!sym || sym->kind != SymKind::kDevice || d.safe.empty()) return;
  Device& dev = out_.devices[sym->index];
  if (!dev_ok_[sym->index]) return;
  if (!(dev.role & core::kRoleActuator)) {
    diags_.emit(DiagKind::kNotAnActuator, d.safe_span, dev.name, "`safe`");
    return;
  }
  if (d.safe.size() > core::kMaxSafeStateCommands) {
    diags_.emit(DiagKind::kTooMany, d.safe_span, d.safe.size(), "safe-state commands",
                core::kMaxSafeStateCommands);
    return;
  }
  for (const auto& call : d.safe) {
    auto cv = command_value(*call, static_cast<uint16_t>(sym->index), CallMode::kTemplate, nullptr,
                            "the safe state of `" + dev.name + "`");
    if (!cv) continue;
    const auto& spec = dev.profile.commands[cv->command];
    if (!cv->index && spec.repeat > 1) {
      // Nothing is being checked when a safe state is written: say which channel.
      diags_.emit(DiagKind::kMissingProperty, call->span, "the safe-state command", spec.name,
                  "channel", "the channel first, e.g. `" + spec.name + "(0, ...)`");
      continue;
    }
    dev.safe.push_back(std::move(*cv));
  }
}

void Sema::unknown_field(const std::string& name, Span span, const Device& dev, uint16_t cmd) {
  std::vector<std::string> names;
  for (const auto& f : dev.profile.commands[cmd].fields) names.push_back(f.name);
  diags_.emit(DiagKind::kUnknownField, span, dev.profile.commands[cmd].name, name,
              join_names(names));
}

std::optional<uint16_t> Sema::find_command(const Device& dev, const std::string& name) const {
  for (size_t i = 0; i < dev.profile.commands.size(); ++i) {
    if (dev.profile.commands[i].name == name) return static_cast<uint16_t>(i);
  }
  return std::nullopt;
}

std::vector<std::string> Sema::command_names(const Device& dev) const {
  std::vector<std::string> names;
  for (const auto& c : dev.profile.commands) {
    if (c.command_class == core::CommandClass::kActuate) names.push_back(c.name);
  }
  return names;
}

// Checks a value against a field's range (values in the field's unit).
bool Sema::in_field_range(const IExprPtr& v, const devices::FieldSpec& f, const std::string& what) {
  if (!v->is_const()) return true;
  const int64_t scale = time_unit_scale(f.unit);
  int64_t value = v->value;
  if (scale) value = v->value / scale;
  if (value < f.min || value > f.max) {
    diags_.emit(DiagKind::kValueOutOfRange, v->span, what, value, f.name, f.min, f.max);
    return false;
  }
  return true;
}

// Checks that a value's type fits a field (duration fields take durations).
bool Sema::value_fits(const IExprPtr& v, const devices::FieldSpec& f) {
  if (v->type == Type::kError) return false;
  const int64_t scale = time_unit_scale(f.unit);
  const Type want = scale ? Type::kDuration : Type::kInt;
  if (v->type != want) {
    diags_.emit(DiagKind::kTypeMismatch, v->span, "the value of `" + f.name + "`",
                type_phrase(v->type),
                scale ? fmt::format("a duration (the field counts {})", f.unit)
                      : std::string("a plain number"));
    return false;
  }
  if (scale && v->is_const() && v->value % scale != 0) {
    diags_.emit(DiagKind::kInexactDuration, v->span, source_text(v->span), f.unit, "1" + f.unit);
    return false;
  }
  return true;
}

// `cmd(args)` on device `dev_id`. In kExpect mode arguments may be ranges,
// sets or `_`; in kTemplate mode they must be constants; in kComputed mode
// they may read signals and the checked command (`rule_cmds`).
std::optional<CommandValue> Sema::command_value(const ast::Expr& call, uint16_t dev_id,
                                                CallMode mode,
                                                const std::vector<uint16_t>* rule_cmds,
                                                const std::string& what) {
  const Device& dev = out_.devices[dev_id];
  auto ci = find_command(dev, call.name);
  if (!ci) {
    diags_.emit(DiagKind::kUnknownCommand, call.name_span, dev.name, call.name,
                join_names(command_names(dev)));
    return std::nullopt;
  }
  const devices::CommandSpec& cmd = dev.profile.commands[*ci];
  if (cmd.command_class != core::CommandClass::kActuate) {
    diags_.emit(DiagKind::kNotActuation, call.name_span, cmd.name,
                cmd.command_class == core::CommandClass::kQuery ? "a query" : "forbidden");
    return std::nullopt;
  }
  CommandValue cv;
  cv.command = *ci;
  cv.span = call.span;
  bool ok = true;
  size_t next_positional = 0;
  bool index_pending = cmd.repeat > 1;
  std::vector<bool> given(cmd.fields.size(), false);
  Ctx ctx;
  ctx.what = what;
  ctx.constant = mode == CallMode::kTemplate;
  ctx.signals = mode != CallMode::kTemplate;
  ctx.device = mode == CallMode::kTemplate ? nullptr : &dev;
  ctx.commands = rule_cmds;
  if (!rule_cmds) ctx.device = nullptr;
  ctx.rule = what;
  for (size_t i = 0; i < call.kids.size(); ++i) {
    const ast::Expr& arg = *call.kids[i];
    const std::string& name = call.arg_names[i];
    // The channel of a repeated register group: first positional or `index=`.
    if ((name.empty() && index_pending) || name == "index" || name == "channel") {
      index_pending = false;
      if (cmd.repeat <= 1) {
        diags_.emit(DiagKind::kUnknownField, call.arg_name_spans[i], cmd.name, name,
                    "its fields; it has no channel");
        ok = false;
        continue;
      }
      if (auto idx = int_in(arg, "the channel", 0, cmd.repeat - 1)) {
        cv.index = *idx;
      } else {
        ok = false;
      }
      continue;
    }
    size_t slot;
    if (name.empty()) {
      while (next_positional < cmd.fields.size() && given[next_positional]) ++next_positional;
      if (next_positional >= cmd.fields.size()) {
        diags_.emit(DiagKind::kArgumentCount, arg.span, cmd.name,
                    fmt::format("{} field values", cmd.fields.size()), "more");
        ok = false;
        break;
      }
      slot = next_positional++;
    } else {
      auto it = std::find_if(cmd.fields.begin(), cmd.fields.end(),
                             [&](const devices::FieldSpec& f) { return f.name == name; });
      if (it == cmd.fields.end()) {
        unknown_field(name, call.arg_name_spans[i], dev, *ci);
        ok = false;
        continue;
      }
      slot = static_cast<size_t>(it - cmd.fields.begin());
      if (given[slot]) {
        diags_.emit(DiagKind::kDuplicateProperty, call.arg_name_spans[i], name);
        ok = false;
        continue;
      }
    }
    given[slot] = true;
    const devices::FieldSpec& f = cmd.fields[slot];
    FieldValue fv;
    fv.slot = static_cast<uint8_t>(slot);
    const std::string fwhat = "`" + cmd.name + "`'s `" + f.name + "`";
    if (mode == CallMode::kExpect && arg.kind == ExprKind::kName && arg.name == "_") {
      continue;  // any value
    }
    if (mode == CallMode::kExpect && arg.kind == ExprKind::kRange) {
      fv.lo_value = resolve(*arg.kids[0], ctx);
      fv.hi_value = resolve(*arg.kids[1], ctx);
      if (!value_fits(fv.lo_value, f) || !value_fits(fv.hi_value, f)) {
        ok = false;
        continue;
      }
      if (fv.lo_value->is_const() && fv.hi_value->is_const() &&
          fv.lo_value->value > fv.hi_value->value) {
        diags_.emit(DiagKind::kEmptyRange, arg.span, fv.lo_value->value, fv.hi_value->value);
        ok = false;
        continue;
      }
      ok = in_field_range(fv.lo_value, f, fwhat) && ok;
      ok = in_field_range(fv.hi_value, f, fwhat) && ok;
    } else if (mode == CallMode::kExpect && arg.kind == ExprKind::kSet) {
      for (const auto& k : arg.kids) {
        IExprPtr v = resolve(*k, ctx);
        if (!value_fits(v, f)) {
          ok = false;
          continue;
        }
        ok = in_field_range(v, f, fwhat) && ok;
        fv.set.push_back(v);
      }
      if (fv.set.empty()) ok = false;
    } else {
      fv.value = resolve(arg, ctx);
      if (!value_fits(fv.value, f)) {
        ok = false;
        continue;
      }
      ok = in_field_range(fv.value, f, fwhat) && ok;
    }
    cv.fields.push_back(std::move(fv));
  }
  if (index_pending && mode == CallMode::kTemplate) {
    // no channel given: the checked command's channel is kept
  }
  if (!ok) return std::nullopt;
  return cv;
}

// Resolves a selector's command list (names or groups) to actuation commands.
std::optional<std::vector<uint16_t>> Sema::selector_commands(const ast::Selector& s,
                                                             uint16_t dev_id) {
  const Device& dev = out_.devices[dev_id];
  std::vector<uint16_t> cmds;
  bool ok = true;
  for (const auto& name : s.commands) {
    bool found = false;
    for (size_t i = 0; i < dev.profile.commands.size(); ++i) {
      const auto& c = dev.profile.commands[i];
      if (c.name == name.name || c.group == name.name) {
        if (c.command_class != core::CommandClass::kActuate) {
          if (c.name == name.name) {
            diags_.emit(DiagKind::kNotActuation, name.span, c.name,
                        c.command_class == core::CommandClass::kQuery ? "a query" : "forbidden");
            ok = false;
          }
          found = true;
          continue;
        }
        found = true;
        if (std::find(cmds.begin(), cmds.end(), i) == cmds.end()) {
          cmds.push_back(static_cast<uint16_t>(i));
        }
      }
    }
    if (!found) {
      diags_.emit(DiagKind::kUnknownCommand, name.span, dev.name, name.name,
                  join_names(command_names(dev)));
      ok = false;
    }
  }
  if (!ok) return std::nullopt;
  std::sort(cmds.begin(), cmds.end());
  return cmds;
}

std::vector<uint16_t> Sema::all_actuation(const Device& dev) const {
  std::vector<uint16_t> cmds;
  for (size_t i = 0; i < dev.profile.commands.size(); ++i) {
    if (dev.profile.commands[i].command_class == core::CommandClass::kActuate) {
      cmds.push_back(static_cast<uint16_t>(i));
    }
  }
  return cmds;
}

// Looks up a device by name for a rule; reports and returns nullopt if bad.
std::optional<uint16_t> Sema::rule_device(const ast::Ident& id, const std::string& what,
                                          bool need_actuator) {
  const Sym* sym = lookup_as(id.name, id.span, SymKind::kDevice, "a device");
  if (!sym || !dev_ok_[sym->index]) return std::nullopt;
  const Device& dev = out_.devices[sym->index];
  if (need_actuator && !(dev.role & core::kRoleActuator)) {
    diags_.emit(DiagKind::kNotAnActuator, id.span, id.name, what);
    return std::nullopt;
  }
  return static_cast<uint16_t>(sym->index);
}

std::optional<uint16_t> Sema::rule_task(const ast::Ident& id) {
  const Sym* sym = lookup_as(id.name, id.span, SymKind::kTask, "a task");
  if (!sym) return std::nullopt;
  return static_cast<uint16_t>(sym->index);
}

}  // namespace contego::policy::check_internal
