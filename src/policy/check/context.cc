#include "policy/check/context.h"

#include <algorithm>

#include "base/phrase.h"

namespace contego::policy::check_internal {

CheckedPolicy Sema::run() {
  for (const auto& c : file_.consts) declare_const(c);
  for (const auto& d : file_.devices) declare_device(d);
  uint32_t overhead_ns = 0;
  for (const auto& o : file_.overheads) {
    if (overhead_seen_) {
      diags_.emit(DiagKind::kDuplicateProperty, o.span, "overhead");
      continue;
    }
    overhead_seen_ = true;
    overhead_ns = duration_ns(*o.value, "`overhead`");
  }
  for (const auto& t : file_.tasks) declare_task(t, overhead_ns);
  for (const auto& s : file_.signals) declare_signal(s);
  for (const auto& d : file_.devices) resolve_safe_state(d);
  for (const auto& a : file_.allows) apply_allow(a);
  for (const auto& l : file_.limits) check_limit(l);
  for (const auto& i : file_.invariants) check_invariant(i);
  default_max_ages();
  final_checks();
  return std::move(out_);
}

std::string Sema::sym_phrase(SymKind k) {
  static constexpr PhraseTable<SymKind> kPhrases[] = {
      {SymKind::kConst, "a constant"}, {SymKind::kDevice, "a device"},
      {SymKind::kSignal, "a signal"},  {SymKind::kListSignal, "a list signal"},
      {SymKind::kTask, "a task"},      {SymKind::kInvariant, "an invariant"}};
  return std::string(phrase_of(k, kPhrases, "a name"));
}

bool Sema::declare(const std::string& name, SymKind kind, size_t index, Span span) {
  auto [it, inserted] = names_.emplace(name, Sym{kind, index, span});
  if (!inserted) {
    diags_.emit(DiagKind::kDuplicateName, span, name, sym_phrase(it->second.kind));
    diags_.note(DiagKind::kPreviousDeclaration, it->second.span, name);
    return false;
  }
  return true;
}

const Sema::Sym* Sema::lookup(const std::string& name) const {
  auto it = names_.find(name);
  return it == names_.end() ? nullptr : &it->second;
}

const Sema::Sym* Sema::lookup_as(const std::string& name, Span at, SymKind kind,
                                 const std::string& phrase) {
  const Sym* sym = lookup(name);
  if (!sym) {
    diags_.emit(DiagKind::kUnknownName, at, name, phrase);
    return nullptr;
  }
  if (sym->kind != kind) {
    diags_.emit(DiagKind::kTypeMismatch, at, "`" + name + "`", sym_phrase(sym->kind), phrase);
    return nullptr;
  }
  return sym;
}

// A sensor without `max_age` gets the documented default: twice its sample
// period, or the longest period of a task that may read it when that is
// longer (a controller reads at the start of its job and commands within
// the period, judged against that reading). Never unbounded: a sensor that
// stops answering makes its signals unavailable.
void Sema::default_max_ages() {
  for (size_t i = 0; i < out_.devices.size(); ++i) {
    Device& d = out_.devices[i];
    if (!(d.role & core::kRoleSensor) || d.max_age_declared) continue;
    uint64_t age = uint64_t{2} * d.sample_period_us;
    for (const Task& t : out_.tasks) {
      if (i < t.read.size() && t.read[i]) age = std::max<uint64_t>(age, t.period_us);
    }
    d.max_age_us = static_cast<uint32_t>(std::min<uint64_t>(age, UINT32_MAX));
  }
}

void Sema::final_checks() {
  for (size_t i = 0; i < out_.devices.size(); ++i) {
    const Device& d = out_.devices[i];
    if ((d.role & core::kRoleActuator) && !d.commanded && dev_ok_[i] && !all_actuation(d).empty()) {
      diags_.emit(DiagKind::kUnusedActuator, d.span, d.name);
    }
  }
  for (const Const& c : consts_) {
    if (!c.used && c.value->type != Type::kError) {
      diags_.emit(DiagKind::kUnusedDeclaration, c.span, "constant", c.name);
    }
  }
  for (size_t i = 0; i < out_.signals.size(); ++i) {
    const Signal& s = out_.signals[i];
    if (!s.used && !s.implicit && !bad_signals_.count(i)) {
      diags_.emit(DiagKind::kUnusedDeclaration, s.span, "signal", s.name);
    }
  }
  for (const auto& [name, span] : aliases_) {
    if (!used_aliases_.count(name)) {
      diags_.emit(DiagKind::kUnusedDeclaration, span, "signal", name);
    }
  }
  // Invariants with the same condition on the same commands.
  for (size_t i = 0; i < out_.invariants.size(); ++i) {
    const Invariant& a = out_.invariants[i];
    if (a.form != InvariantForm::kExpect || !a.when) continue;
    for (size_t j = i + 1; j < out_.invariants.size(); ++j) {
      const Invariant& b = out_.invariants[j];
      if (b.form != InvariantForm::kExpect || !b.when || b.device != a.device ||
          b.index != a.index || to_string(*a.when) != to_string(*b.when)) {
        continue;
      }
      bool same = a.expect.size() == b.expect.size();
      for (const CommandValue& ea : a.expect) {
        const auto& ga = out_.devices[a.device].profile.commands[ea.command].group;
        for (const CommandValue& eb : b.expect) {
          const auto& gb = out_.devices[b.device].profile.commands[eb.command].group;
          if (ga != gb) continue;
          if (!compatible(ea, eb)) {
            diags_.emit(DiagKind::kContradictoryInvariants, b.span, a.name, b.name, ga);
            diags_.note(DiagKind::kPreviousDeclaration, a.span, a.name);
            same = false;
            goto next;
          }
        }
      }
      if (same && a.commands == b.commands) {
        diags_.emit(DiagKind::kShadowedInvariant, b.span, b.name, a.name);
      }
    next:;
    }
  }
}

// Two expectations of one group can both hold: same command and no field
// with two different constant values.
bool Sema::compatible(const CommandValue& a, const CommandValue& b) {
  if (a.command != b.command) return false;
  if (a.index && b.index && *a.index != *b.index) return false;
  for (const FieldValue& fa : a.fields) {
    for (const FieldValue& fb : b.fields) {
      if (fa.slot != fb.slot || !fa.value || !fb.value) continue;
      if (fa.value->is_const() && fb.value->is_const() && fa.value->value != fb.value->value) {
        return false;
      }
    }
  }
  return true;
}

}  // namespace contego::policy::check_internal
