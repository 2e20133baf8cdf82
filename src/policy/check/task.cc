#include "policy/check/context.h"

namespace contego::policy::check_internal {

namespace {

struct Errno {
  const char* name;
  uint8_t value;
};
constexpr Errno kErrnos[] = {{"EPERM", 1},   {"EIO", 5},    {"ENXIO", 6},   {"EAGAIN", 11},
                             {"EACCES", 13}, {"EBUSY", 16}, {"EINVAL", 22}, {"EREMOTEIO", 121}};

}  // namespace

std::optional<uint8_t> Sema::errno_named(const std::string& name, Span at) {
  auto it = std::find_if(std::begin(kErrnos), std::end(kErrnos),
                         [&](const Errno& e) { return name == e.name; });
  if (it != std::end(kErrnos)) return it->value;
  diags_.emit(DiagKind::kUnknownErrno, at, name);
  return std::nullopt;
}

void Sema::declare_task(const ast::TaskDecl& d, uint32_t overhead_ns) {
  Task t;
  t.name = d.name.name;
  t.span = d.name.span;
  t.overhead_ns = overhead_ns;
  std::set<std::string> seen;
  bool have_period = false, have_deadline = false, have_wcet = false;
  for (const auto& p : d.properties) {
    if (!seen.insert(p.key.name).second) {
      diags_.emit(DiagKind::kDuplicateProperty, p.key.span, p.key.name);
      continue;
    }
    const std::string what = "`" + p.key.name + "`";
    if (p.key.name == "exe") {
      t.exe = p.text;
    } else if (p.key.name == "user") {
      t.user = p.text;
    } else if (p.key.name == "group") {
      t.group = p.text;
    } else if (p.key.name == "unit") {
      t.unit = p.text;
    } else if (p.key.name == "cgroup") {
      t.cgroup = p.text;
    } else if (p.key.name == "ignore_errno") {
      if (auto e = errno_named(p.text, p.key.span)) t.ignore_errno = *e;
    } else if (p.key.name == "sessions") {
      if (auto v = int_in(*p.value, "`sessions`", 1, 64)) t.sessions = static_cast<uint32_t>(*v);
    } else if (p.key.name == "period") {
      auto v = const_value(*p.value, Type::kDuration, what);
      have_period = true;
      if (v && (*v <= 0 || *v > std::numeric_limits<uint32_t>::max())) {
        diags_.emit(DiagKind::kValueOutOfRange, p.value->span, what, std::to_string(*v) + "us",
                    "period", "1us", "4294967295us");
      } else if (v) {
        t.period_us = static_cast<uint32_t>(*v);
      }
    } else if (p.key.name == "phase") {
      t.phase_us = duration_us(*p.value, what);
    } else if (p.key.name == "deadline") {
      t.deadline_us = duration_us(*p.value, what);
      have_deadline = true;
    } else if (p.key.name == "wcet") {
      t.wcet_us = duration_us(*p.value, what);
      have_wcet = true;
    } else if (p.key.name == "overhead") {
      t.overhead_ns = duration_ns(*p.value, what);
    } else if (p.key.name == "priority") {
      if (auto v = int_in(*p.value, "`priority`", 0, 65535)) t.priority = static_cast<uint16_t>(*v);
    } else if (p.key.name == "actuations") {
      if (auto v = int_in(*p.value, "`actuations`", 0, 65535)) {
        t.actuations = static_cast<uint16_t>(*v);
        t.actuations_given = true;
      }
    }
  }
  if (!d.incomplete) {
    if (!have_period) {
      diags_.emit(DiagKind::kMissingProperty, d.name.span, "task", t.name, "period",
                  "`period` with a duration such as `200ms`");
    }
    if (!have_wcet) {
      diags_.emit(DiagKind::kMissingProperty, d.name.span, "task", t.name, "wcet",
                  "`wcet` with its worst-case execution time such as `40ms`");
    }
  }
  if (!have_deadline) t.deadline_us = t.period_us;
  if (t.phase_us && have_period && t.period_us != 0 && *t.phase_us >= t.period_us) {
    // A release offset within one period: job k is released at phase + k·period.
    for (const auto& p : d.properties) {
      if (p.key.name == "phase") {
        diags_.emit(DiagKind::kValueOutOfRange, p.value->span, "`phase`",
                    std::to_string(*t.phase_us) + "us", "phase", "0us",
                    std::to_string(t.period_us - 1) + "us (below the period)");
      }
    }
  }
  if (have_deadline && have_period && t.deadline_us > t.period_us) {
    // Constrained deadlines only: the analysis assumes D <= T.
    for (const auto& p : d.properties) {
      if (p.key.name == "deadline") {
        diags_.emit(DiagKind::kValueOutOfRange, p.value->span, "`deadline`",
                    std::to_string(t.deadline_us) + "us", "deadline", "1us",
                    std::to_string(t.period_us) + "us (the period)");
      }
    }
  }
  if (!declare(t.name, SymKind::kTask, out_.tasks.size(), d.name.span)) return;
  out_.tasks.push_back(std::move(t));
}

void Sema::declare_signal(const ast::SignalDecl& d) {
  // A list signal: `signal lf = line.raw`.
  if (d.value->kind == ExprKind::kMember) {
    Ctx probe;
    probe.what = "signal `" + d.name.name + "`";
    const ast::Expr& base = *d.value->kids[0];
    const Sym* sym = base.kind == ExprKind::kName ? lookup(base.name) : nullptr;
    if (sym && sym->kind == SymKind::kDevice && dev_ok_[sym->index]) {
      const auto& fields = out_.devices[sym->index].profile.sample_fields;
      const bool scalar = std::any_of(fields.begin(), fields.end(),
                                      [&](const auto& f) { return f.name == d.value->name; });
      if (!scalar) {
        auto ids = resolve_member(*d.value, probe);
        if (!ids) return;
        if (declare(d.name.name, SymKind::kListSignal, list_signals_.size(), d.name.span)) {
          list_signals_.push_back(*ids);
          list_spans_.push_back(d.name.span);
        }
        return;
      }
    }
  }
  Ctx ctx;
  ctx.what = "signal `" + d.name.name + "`";
  ctx.signal_limit = out_.signals.size();
  IExprPtr v = resolve(*d.value, ctx);
  if (v->type == Type::kError) {
    // Declare anyway (as an unavailable int) so later uses do not cascade.
    if (!lookup(d.name.name)) {
      Signal s;
      s.name = d.name.name;
      s.span = d.name.span;
      s.value = make_const(0, Type::kInt, d.name.span);
      s.used = true;
      declare(s.name, SymKind::kSignal, out_.signals.size(), d.name.span);
      bad_signals_.insert(out_.signals.size());
      out_.signals.push_back(std::move(s));
    }
    return;
  }
  Signal s;
  s.name = d.name.name;
  s.span = d.name.span;
  s.type = v->type;
  s.lo = v->lo;
  s.hi = v->hi;
  if (v->op == IOp::kSignal && !v->kids.size()) {
    // `signal level = tank.level`: an alias of a raw signal.
    // The raw signal keeps its `device.value` name (tools map sample
    // values by it); the new name is an alias in the namespace.
    const Signal& target = out_.signals[v->slot];
    if (target.raw) {
      if (!declare(d.name.name, SymKind::kSignal, v->slot, d.name.span)) return;
      aliases_.push_back({d.name.name, d.name.span});
      out_.signal_aliases.emplace_back(d.name.name, v->slot);
      return;
    }
  }
  s.value = v;
  if (!declare(s.name, SymKind::kSignal, out_.signals.size(), d.name.span)) return;
  out_.signals.push_back(std::move(s));
}

void Sema::apply_allow(const ast::AllowDecl& a) {
  auto task = rule_task(a.task);
  for (const auto& d : a.devices) {
    auto dev = rule_device(d, a.reads ? "`allow ... reads`" : "`allow ... ->`", !a.reads);
    if (!task || !dev) continue;
    Task& t = out_.tasks[*task];
    t.actuate.resize(out_.devices.size());
    t.read.resize(out_.devices.size());
    if (a.reads) {
      const Device& device = out_.devices[*dev];
      // Sensors, devices with query commands, and devices whose registers
      // drivers read back (the PCA9685's MODE1 before changing it).
      const bool readable =
          (device.role & core::kRoleSensor) || device.profile.read_back ||
          std::any_of(device.profile.commands.begin(), device.profile.commands.end(),
                      [](const auto& c) { return c.command_class == core::CommandClass::kQuery; });
      if (!readable) {
        diags_.emit(DiagKind::kReadOfActuatorOnly, d.span, a.task.name, d.name);
        continue;
      }
      t.read[*dev] = true;
    } else {
      t.actuate[*dev] = true;
      out_.devices[*dev].commanded = true;
    }
  }
}

std::optional<Response> Sema::response(const ast::Response& r, uint16_t dev_id,
                                       const std::vector<uint16_t>& cmds, bool in_invariant,
                                       bool has_expected, const std::string& rule) {
  Response out;
  out.text = source_text(r.span);
  switch (r.kind) {
    case ast::ResponseKind::kNone:
      return std::nullopt;
    case ast::ResponseKind::kIgnore:
      out.kind = ResponseKind::kIgnore;
      return out;
    case ast::ResponseKind::kReject: {
      out.kind = ResponseKind::kReject;
      out.reply_errno = 1;
      if (!r.errno_name.name.empty()) {
        auto e = errno_named(r.errno_name.name, r.errno_name.span);
        if (!e) return std::nullopt;
        out.reply_errno = *e;
      }
      return out;
    }
    case ast::ResponseKind::kFailsafeExpected:
      if (!has_expected) {
        diags_.emit(DiagKind::kExpectedWithoutExpect, r.span);
        return std::nullopt;
      }
      out.kind = ResponseKind::kFailsafeExpected;
      return out;
    case ast::ResponseKind::kFailsafeCommand: {
      auto cv = command_value(*r.command, dev_id, CallMode::kComputed, &cmds,
                              "the fail-safe command of " + rule);
      if (!cv) return std::nullopt;
      if (cv->index && !cv->constant()) {
        // A constant command carries its channel (TemplateRecord::index); a
        // computed one (FAIL_SUBST) is always written to the checked channel.
        diags_.emit(DiagKind::kNotSupported, r.command->span,
                    "a computed fail-safe command for another channel (a computed "
                    "substitute keeps the checked command's channel)");
        return std::nullopt;
      }
      out.kind = cv->constant() ? ResponseKind::kFailsafeTemplate : ResponseKind::kFailsafeComputed;
      if (!in_invariant && !cv->constant()) {
        diags_.emit(DiagKind::kComputedTemplate, r.command->span,
                    "the fail-safe command of " + rule,
                    "values known only when the command is checked");
        return std::nullopt;
      }
      clear_unnamed_overrides(*cv, out_.devices[dev_id], cmds);
      out.command = std::move(cv);
      return out;
    }
    case ast::ResponseKind::kFailsafeAssign: {
      // Same command, some fields forced: the field must sit in the same slot everywhere.
      const Device& dev = out_.devices[dev_id];
      CommandValue cv;
      cv.command = core::kNone;
      cv.span = r.span;
      Ctx ctx;
      ctx.what = "the fail-safe value of " + rule;
      ctx.device = &dev;
      ctx.commands = &cmds;
      ctx.rule = rule;
      bool ok = true;
      for (const auto& a : r.assigns) {
        IExprPtr slot_ref = field_ref(a.field.name, a.field.span, ctx, IOp::kField);
        if (!slot_ref) {
          unknown_field(a.field.name, a.field.span, dev, cmds.empty() ? 0 : cmds[0]);
          ok = false;
          continue;
        }
        if (slot_ref->type == Type::kError) {
          ok = false;
          continue;
        }
        IExprPtr v = resolve(*a.value, ctx);
        if (v->type == Type::kError) {
          ok = false;
          continue;
        }
        // Range of the field in every command.
        for (uint16_t ci : cmds) {
          const auto& f = dev.profile.commands[ci].fields[slot_ref->slot];
          if (!value_fits(v, f) || !in_field_range(v, f, "the fail-safe value")) {
            ok = false;
            break;
          }
        }
        FieldValue fv;
        fv.slot = static_cast<uint8_t>(slot_ref->slot);
        fv.value = v;
        cv.fields.push_back(fv);
      }
      if (!ok) return std::nullopt;
      clear_unnamed_overrides(cv, dev, cmds);
      out.kind = cv.constant() ? ResponseKind::kFailsafeTemplate : ResponseKind::kFailsafeComputed;
      if (!in_invariant && !cv.constant()) {
        diags_.emit(DiagKind::kComputedTemplate, r.span, "the fail-safe value of " + rule,
                    "values known only when the command is checked");
        return std::nullopt;
      }
      out.command = std::move(cv);
      return out;
    }
  }
  return std::nullopt;
}

// A fail-safe never inherits an output override (full on / full off) from
// the device's shadow: the ones it does not name are written as 0.
void Sema::clear_unnamed_overrides(CommandValue& cv, const Device& dev,
                                   const std::vector<uint16_t>& cmds) {
  if (dev.profile.kind != core::Profile::kRegisterMap) return;
  std::vector<uint16_t> which;
  if (cv.command != core::kNone) {
    which.push_back(cv.command);
  } else {
    which = cmds;
  }
  if (which.empty()) return;
  const auto& first = dev.profile.commands[which[0]].fields;
  for (size_t slot = 0; slot < first.size(); ++slot) {
    const bool everywhere = std::all_of(which.begin(), which.end(), [&](uint16_t ci) {
      const auto& fields = dev.profile.commands[ci].fields;
      return slot < fields.size() && fields[slot].output_override &&
             fields[slot].name == first[slot].name;
    });
    const bool named = std::any_of(cv.fields.begin(), cv.fields.end(),
                                   [&](const FieldValue& f) { return f.slot == slot; });
    if (!everywhere || named) continue;
    FieldValue fv;
    fv.slot = static_cast<uint8_t>(slot);
    fv.value = make_const(0, Type::kInt, cv.span);
    cv.fields.push_back(fv);
  }
}

}  // namespace contego::policy::check_internal
