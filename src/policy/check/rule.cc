#include <algorithm>

#include "policy/check/context.h"

namespace contego::policy::check_internal {

void Sema::check_limit(const ast::LimitDecl& l) {
  auto task = rule_task(l.task);
  auto dev = rule_device(l.target.device, "a rate limit", true);
  auto count = int_in(*l.count, "the rate limit", 0, std::numeric_limits<uint16_t>::max());
  if (!dev) return;
  std::vector<uint16_t> cmds;
  if (l.target.commands.empty()) {
    cmds = all_actuation(out_.devices[*dev]);
  } else if (auto c = selector_commands(l.target, *dev)) {
    cmds = *c;
  } else {
    return;
  }
  std::optional<int64_t> channel;
  if (l.target.index) {
    channel = selected_channel(*l.target.index, l.target.span, cmds, out_.devices[*dev]);
    if (!channel) return;
  }
  const std::string rule = "the rate limit `" + source_text(l.target.span) + "`";
  auto resp = response(l.response, *dev, cmds, false, false, rule);
  if (!task || !count || !resp) return;
  Task& t = out_.tasks[*task];
  t.actuate.resize(out_.devices.size());
  if (!t.actuate[*dev]) {
    diags_.emit(DiagKind::kRateWithoutAccess, l.span, t.name, out_.devices[*dev].name);
  }
  if (t.actuations_given && *count > t.actuations) {
    diags_.emit(DiagKind::kRateAboveActuations, l.count->span, *count, t.name, t.actuations);
  }
  RateLimit r;
  r.name = t.name + "->" + source_text(l.target.span);
  r.task = *task;
  r.device = *dev;
  r.commands = cmds;
  r.count = static_cast<uint32_t>(*count);
  r.index = channel;
  r.response = std::move(*resp);
  r.text = one_line(source_text(l.span), /*drop_comments=*/true);
  r.span = l.span;
  out_.rates.push_back(std::move(r));
}

// The channel of a selection `dev.led(5)`: a repeated register group's
// channel, within its repeat count.
std::optional<int64_t> Sema::selected_channel(const ast::Expr& index, Span target,
                                              const std::vector<uint16_t>& cmds,
                                              const Device& device) {
  int64_t max_repeat = 1;
  for (uint16_t ci : cmds) {
    max_repeat = std::max<int64_t>(max_repeat, device.profile.commands[ci].repeat);
  }
  if (max_repeat <= 1) {
    diags_.emit(DiagKind::kTypeMismatch, index.span, "`" + source_text(target) + "`",
                "a command without channels", "a repeated register group such as `led`");
    return std::nullopt;
  }
  return int_in(index, "the channel", 0, max_repeat - 1);
}

IExprPtr Sema::condition(const ast::Expr& e, const Ctx& ctx) {
  IExprPtr v = resolve(e, ctx);
  if (v->type == Type::kError) return nullptr;
  if (v->type != Type::kBool) {
    diags_.emit(DiagKind::kTypeMismatch, e.span, "the condition", type_phrase(v->type),
                "a boolean (a comparison, `in`, `and`, `or`, `not`)");
    return nullptr;
  }
  return v;
}

void Sema::check_invariant(const ast::InvariantDecl& d) {
  Invariant inv;
  inv.name = d.name.name;
  inv.span = d.name.span;
  inv.text = one_line(source_text(d.span), /*drop_comments=*/true);
  const bool declared = declare(inv.name, SymKind::kInvariant, out_.invariants.size(), d.name.span);
  auto dev = rule_device(d.target.device, "an invariant", true);
  if (!dev) return;
  inv.device = *dev;
  const Device& device = out_.devices[*dev];
  bool ok = true;
  std::vector<uint16_t> cmds;
  if (!d.target.commands.empty()) {
    auto c = selector_commands(d.target, *dev);
    if (!c) return;
    cmds = *c;
  }
  if (d.target.index) {
    inv.index = selected_channel(*d.target.index, d.target.span,
                                 cmds.empty() ? all_actuation(device) : cmds, device);
    if (!inv.index) ok = false;
  }
  const std::string rule = "invariant `" + inv.name + "`";
  // Expected commands first: they decide the default command set.
  if (d.form == ast::InvariantForm::kExpect) {
    inv.form = InvariantForm::kExpect;
    std::set<std::string> groups;
    for (const auto& call : d.expect) {
      auto cv =
          command_value(*call, *dev, CallMode::kExpect, nullptr, "an expected command of " + rule);
      if (!cv) {
        ok = false;
        continue;
      }
      const auto& spec = device.profile.commands[cv->command];
      if (!groups.insert(spec.group).second) {
        diags_.emit(DiagKind::kGroupExpectedTwice, call->span, spec.group);
        ok = false;
        continue;
      }
      if (!d.target.commands.empty() &&
          std::find(cmds.begin(), cmds.end(), cv->command) == cmds.end()) {
        diags_.emit(DiagKind::kUnknownCommand, call->name_span, source_text(d.target.span),
                    spec.name, "the ones it selects; expected a command it applies to");
        ok = false;
        continue;
      }
      inv.expect.push_back(std::move(*cv));
    }
    if (d.target.commands.empty()) {
      for (size_t i = 0; i < device.profile.commands.size(); ++i) {
        const auto& c = device.profile.commands[i];
        if (c.command_class == core::CommandClass::kActuate && groups.count(c.group)) {
          cmds.push_back(static_cast<uint16_t>(i));
        }
      }
    }
  } else if (d.form == ast::InvariantForm::kSequence) {
    inv.form = InvariantForm::kSequence;
    if (cmds.empty()) cmds = all_actuation(device);
  } else {
    inv.form = InvariantForm::kRequire;
    if (cmds.empty()) cmds = all_actuation(device);
  }
  if (cmds.empty() && ok) {
    diags_.emit(DiagKind::kUnknownCommand, d.target.span, device.name, "(any)",
                "none it could apply to");
    ok = false;
  }
  inv.commands = cmds;
  Ctx ctx;
  ctx.what = "the condition of " + rule;
  ctx.device = &device;
  ctx.commands = &inv.commands;
  ctx.rule = rule;
  if (d.when) {
    inv.when = condition(*d.when, ctx);
    if (!inv.when) ok = false;
    if (inv.when && inv.when->lo == 0 && inv.when->hi == 0) {
      diags_.emit(DiagKind::kConstantCondition, d.when->span, inv.name, "false",
                  "the invariant never applies");
    }
  }
  if (d.form == ast::InvariantForm::kRequire && d.require) {
    inv.require = condition(*d.require, ctx);
    if (!inv.require) ok = false;
    if (inv.require && inv.require->lo == inv.require->hi) {
      diags_.emit(DiagKind::kConstantCondition, d.require->span, inv.name,
                  inv.require->lo ? "true" : "false",
                  inv.require->lo ? "the invariant never refuses a command"
                                  : "the invariant refuses every command it applies to");
    }
  }
  if (d.form == ast::InvariantForm::kSequence && ok) {
    IExprPtr f = field_ref(d.sequence_field.name, d.sequence_field.span, ctx, IOp::kField);
    if (!f) {
      unknown_field(d.sequence_field.name, d.sequence_field.span, device, cmds[0]);
      ok = false;
    } else if (f->type == Type::kError) {
      ok = false;
    } else {
      inv.sequence_slot = static_cast<uint8_t>(f->slot);
      if (auto values = const_list(*d.sequence_values, "the sequence")) {
        if (values->empty()) {
          diags_.emit(DiagKind::kListLength, d.sequence_values->span, "sequence", 0,
                      "at least one value");
          ok = false;
        }
        for (size_t i = 0; i < values->size(); ++i) {
          const auto& spec = device.profile.commands[cmds[0]].fields[f->slot];
          if ((*values)[i] < spec.min || (*values)[i] > spec.max) {
            diags_.emit(DiagKind::kValueOutOfRange, d.sequence_values->kids[i]->span,
                        "sequence value", (*values)[i], spec.name, spec.min, spec.max);
            ok = false;
          }
        }
        inv.sequence = *values;
      } else {
        ok = false;
      }
    }
    if (const std::string& scope = d.scope.name; scope.empty() || scope == "session") {
      inv.scope = core::StateScope::kSession;
    } else if (scope == "task") {
      inv.scope = core::StateScope::kTask;
    } else if (scope == "device") {
      inv.scope = core::StateScope::kDevice;
    } else {
      diags_.emit(DiagKind::kUnknownName, d.scope.span, scope,
                  "a state scope: `session`, `task` or `device`");
      ok = false;
    }
  }
  auto resp = response(d.response, *dev, cmds, true, d.form != ast::InvariantForm::kRequire, rule);
  if (!resp) return;
  inv.response = std::move(*resp);
  if (!ok || !declared) return;
  warn_if_never_starts(inv, d.span);
  out_.invariants.push_back(std::move(inv));
}

// True if `e` reads the command history where no default guards it: before
// the first command of its kind reached the device, it faults.
bool Sema::reads_unguarded_history(const IExpr* e) {
  if (!e) return false;
  if (e->op == IOp::kLastField || e->op == IOp::kSinceLast) return true;
  if (e->op == IOp::kLastOr) return reads_unguarded_history(e->kids[1].get());
  return std::any_of(e->kids.begin(), e->kids.end(),
                     [](const IExprPtr& k) { return reads_unguarded_history(k.get()); });
}

// A rule whose check faults until a command reached the device, and whose
// response then writes nothing, refuses every command forever: the history
// it waits for never starts. A constant or expected fail-safe writes a
// command, so it is not reported.
void Sema::warn_if_never_starts(const Invariant& inv, Span span) {
  const IExpr* cond = reads_unguarded_history(inv.when.get())      ? inv.when.get()
                      : reads_unguarded_history(inv.require.get()) ? inv.require.get()
                                                                   : nullptr;
  if (!cond) return;
  bool writes = inv.response.kind == ResponseKind::kFailsafeTemplate ||
                inv.response.kind == ResponseKind::kFailsafeExpected;
  if (inv.response.kind == ResponseKind::kFailsafeComputed && inv.response.command) {
    writes =
        std::none_of(inv.response.command->fields.begin(), inv.response.command->fields.end(),
                     [](const FieldValue& f) { return reads_unguarded_history(f.value.get()); });
  }
  if (writes) return;
  diags_.emit(DiagKind::kNeverStarts, cond->span.end > cond->span.begin ? cond->span : span,
              inv.name);
}

}  // namespace contego::policy::check_internal
