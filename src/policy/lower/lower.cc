#include "policy/lower/lower.h"

#include <algorithm>
#include <limits>
#include <map>

#include "contego/core/limits.h"

#include "devices/lower.h"

namespace contego::policy {
namespace {

using core::Insn;
using core::Op;

// A program under construction, with forward labels.
class Program {
 public:
  size_t size() const { return code_.size(); }
  void emit(Op op, uint16_t b = 0, int32_t imm = 0) { code_.push_back(Insn{op, 0, b, imm}); }
  int new_label() {
    labels_.push_back(-1);
    return static_cast<int>(labels_.size() - 1);
  }
  void jump(Op op, int label) {
    fixups_.emplace_back(code_.size(), label);
    emit(op, 0, 0);
  }
  void bind(int label) { labels_[static_cast<size_t>(label)] = static_cast<int64_t>(code_.size()); }
  std::vector<Insn> finish() {
    for (auto [at, label] : fixups_) {
      code_[at].imm =
          static_cast<int32_t>(labels_[static_cast<size_t>(label)] - static_cast<int64_t>(at));
    }
    return std::move(code_);
  }

 private:
  std::vector<Insn> code_;
  std::vector<int64_t> labels_;
  std::vector<std::pair<size_t, int>> fixups_;
};

core::CommandMask mask_of(const std::vector<uint16_t>& global_ids) {
  core::CommandMask m{};
  for (uint16_t id : global_ids) m.bits[id / 32] |= 1u << (id % 32);
  return m;
}

class Lowerer {
 public:
  Lowerer(const CheckedPolicy& p, DiagnosticEmitter& diags) : p_(p), diags_(diags) {}

  LowerResult run() {
    LowerResult r;
    if (!limits()) return r;
    for (const Device& d : p_.devices) {
      devices::DeviceBinding b;
      b.name = d.name;
      b.bus = d.bus;
      b.addr = d.addr;
      b.sample_period_us = d.sample_period_us;
      b.max_sample_age_us = d.max_age_us;
      if (d.latch_count) {
        b.latch_mode =
            d.latch_unrepaired ? core::LatchMode::kHoldSafeUnrepaired : core::LatchMode::kHoldSafe;
        b.latch_count = d.latch_count;
        b.latch_window_us = d.latch_window_us;
      }
      auto id = devices::append_device(m_, d.profile, b);
      if (!id) {
        diags_.emit(DiagKind::kNotSupported, d.span, "device `" + d.name + "`: " + id.error());
        return r;
      }
    }
    // Safe states.
    for (size_t i = 0; i < p_.devices.size(); ++i) {
      const Device& d = p_.devices[i];
      if (d.safe.empty()) continue;
      auto& rec = m_.devices[i].record;
      rec.safe_first = static_cast<uint16_t>(m_.templates.size());
      rec.safe_count = static_cast<uint16_t>(d.safe.size());
      for (const CommandValue& cv : d.safe) m_.templates.push_back(make_template(i, cv, true));
    }
    for (const Task& t : p_.tasks) {
      image::Named<core::TaskRecord> rec;
      rec.name = t.name;
      rec.record.period_us = t.period_us;
      rec.record.deadline_us = t.deadline_us;
      rec.record.wcet_us = t.wcet_us;
      rec.record.priority = t.priority;
      rec.record.actuations_per_job = t.actuations;
      rec.record.overhead_ns = t.overhead_ns;
      m_.tasks.push_back(rec);
      core::AccessRecord a{};
      for (size_t k = 0; k < t.actuate.size(); ++k) {
        if (t.actuate[k]) a.actuate_devices |= 1u << k;
      }
      for (size_t k = 0; k < t.read.size(); ++k) {
        if (t.read[k]) a.read_devices |= 1u << k;
      }
      m_.access.push_back(a);
    }
    for (size_t i = 0; i < p_.signals.size(); ++i) lower_signal(i);
    for (const RateLimit& rl : p_.rates) lower_rate(rl);
    for (const Invariant& inv : p_.invariants) lower_invariant(inv);
    if (m_.code.size() > core::kMaxCodeWords) {
      diags_.emit(DiagKind::kTooMany, Span{}, m_.code.size(), "bytecode instructions",
                  core::kMaxCodeWords);
      return r;
    }
    if (m_.templates.size() > core::kMaxTemplates) {
      diags_.emit(DiagKind::kTooMany, Span{}, m_.templates.size(), "fail-safe templates",
                  core::kMaxTemplates);
      return r;
    }
    if (m_.constants.size() > core::kMaxConstants) {
      diags_.emit(DiagKind::kTooMany, Span{}, m_.constants.size(), "large constants",
                  core::kMaxConstants);
      return r;
    }
    r.estimated_cost = estimate_cost();
    r.ok = !failed_;
    r.model = std::move(m_);
    return r;
  }

 private:
  bool limits() {
    bool bad = false;
    auto check = [&](size_t n, size_t max, const char* what, Span at) {
      if (n <= max) return;
      diags_.emit(DiagKind::kTooMany, at, n, what, max);
      bad = true;
    };
    // Too many items are reported at the last of them.
    auto last_span = [](const auto& items) { return items.empty() ? Span{} : items.back().span; };
    size_t commands = 0;
    for (const Device& d : p_.devices) commands += d.profile.commands.size();
    check(p_.devices.size(), core::kMaxDevices, "devices", last_span(p_.devices));
    check(commands, core::kMaxCommandDefs, "device commands (all profiles)", last_span(p_.devices));
    check(p_.tasks.size(), core::kMaxTasks, "tasks", last_span(p_.tasks));
    check(p_.signals.size(), core::kMaxSignals, "signals", last_span(p_.signals));
    check(p_.rates.size(), core::kMaxRateLimits, "rate limits", last_span(p_.rates));
    check(p_.invariants.size(), core::kMaxInvariants, "invariants", last_span(p_.invariants));
    return !bad;
  }

  uint16_t global(size_t device, uint16_t command) const {
    return static_cast<uint16_t>(m_.devices[device].record.command_first + command);
  }
  std::vector<uint16_t> globals(size_t device, const std::vector<uint16_t>& cmds) const {
    std::vector<uint16_t> out;
    for (uint16_t c : cmds) out.push_back(global(device, c));
    return out;
  }
  const devices::FieldSpec& field_spec(size_t device, uint16_t command, uint8_t slot) const {
    return p_.devices[device].profile.commands[command].fields[slot];
  }
  static int64_t unit_scale(const devices::FieldSpec& f) {
    if (f.unit == "ms") return 1000;
    if (f.unit == "s") return 1000000;
    return 1;
  }

  // A constant command: every field it names set, the others 0 (for another
  // command) or kept (command == kNone: the checked command). Its channel is
  // the one named; unnamed, a safe state's register-map command goes to
  // channel 0 (it has no checked command) and a rule's keeps the checked one.
  core::TemplateRecord make_template(size_t device, const CommandValue& cv, bool safe_state) {
    core::TemplateRecord t{};
    t.index = core::kSameIndex;
    if (cv.command == core::kNone) {
      t.command = core::kNone;
      for (const FieldValue& f : cv.fields) {
        t.set_mask = static_cast<uint8_t>(t.set_mask | (1u << f.slot));
        t.values[f.slot] = static_cast<int32_t>(f.value->value);
      }
      return t;
    }
    t.command = global(device, cv.command);
    const auto& spec = p_.devices[device].profile.commands[cv.command];
    if (p_.devices[device].profile.kind == core::Profile::kRegisterMap) {
      if (cv.index) {
        t.index = static_cast<uint8_t>(*cv.index);
      } else if (safe_state) {
        t.index = 0;
      }
    }
    for (size_t s = 0; s < spec.fields.size(); ++s) {
      t.set_mask = static_cast<uint8_t>(t.set_mask | (1u << s));
      t.values[s] =
          static_cast<int32_t>(std::clamp<int64_t>(0, spec.fields[s].min, spec.fields[s].max));
    }
    for (const FieldValue& f : cv.fields) {
      const int64_t scale = unit_scale(spec.fields[f.slot]);
      t.values[f.slot] = static_cast<int32_t>(f.value->value / scale);
    }
    return t;
  }

  // A device-scope sequence goes on from where the device's safe state
  // leaves the mechanism: 1 + the position after the last value the safe
  // state writes to the sequence's field; 0 (unchanged) if it writes none of
  // the sequence's values.
  uint8_t after_safe_state(const Invariant& inv) const {
    const size_t n = inv.sequence.size();
    if (inv.form != InvariantForm::kSequence || inv.scope != core::StateScope::kDevice || n > 254)
      return 0;
    const std::vector<uint16_t> covered = globals(inv.device, inv.commands);
    const core::DeviceRecord& d = m_.devices[inv.device].record;
    uint8_t after = 0;
    for (uint32_t k = d.safe_first; k < static_cast<uint32_t>(d.safe_first) + d.safe_count; ++k) {
      const core::TemplateRecord& t = m_.templates[k];
      if (std::find(covered.begin(), covered.end(), t.command) == covered.end() ||
          (inv.index && t.index != *inv.index)) {
        continue;
      }
      const auto at =
          std::find(inv.sequence.begin(), inv.sequence.end(), int64_t{t.values[inv.sequence_slot]});
      after = static_cast<uint8_t>(
          at == inv.sequence.end() ? 0 : (at - inv.sequence.begin() + 1) % n + 1);
    }
    return after;
  }

  uint16_t add_template(const core::TemplateRecord& t) {
    m_.templates.push_back(t);
    return static_cast<uint16_t>(m_.templates.size() - 1);
  }

  // --- expressions -----------------------------------------------------------
  void push_const(Program& p, int64_t v) {
    if (v >= std::numeric_limits<int32_t>::min() && v <= std::numeric_limits<int32_t>::max()) {
      p.emit(Op::kPush, 0, static_cast<int32_t>(v));
      return;
    }
    auto it = std::find(m_.constants.begin(), m_.constants.end(), v);
    if (it == m_.constants.end()) {
      m_.constants.push_back(v);
      it = m_.constants.end() - 1;
    }
    p.emit(Op::kPushConst, static_cast<uint16_t>(it - m_.constants.begin()));
  }

  // Jumps to `to` when `e` is false. A conjunction whose right side cannot
  // fault tests its sides in turn: the same outcome as AND (B evaluated when
  // A is false could only give false), and the core fuses each
  // `FIELD; PUSH; <compare>; JZ` into one step.
  void jump_unless(Program& p, const IExpr& e, int to) {
    if (e.op == IOp::kAnd && !can_fault(*e.kids[1])) {
      jump_unless(p, *e.kids[0], to);
      jump_unless(p, *e.kids[1], to);
      return;
    }
    expr(p, e);
    p.jump(Op::kJumpIfZero, to);
  }

  // Whether evaluating `e` may end the program (a missing signal or history,
  // an overflow, a division by zero): only the command's own unscaled fields,
  // its channel and constants, compared and combined, cannot.
  static bool can_fault(const IExpr& e) {
    switch (e.op) {
      case IOp::kConst:
      case IOp::kIndex:
        return false;
      case IOp::kField:
        return e.scale != 1;
      case IOp::kNot:
      case IOp::kEq:
      case IOp::kNe:
      case IOp::kLt:
      case IOp::kLe:
      case IOp::kGt:
      case IOp::kGe:
      case IOp::kAnd:
      case IOp::kOr:
        for (const auto& k : e.kids) {
          if (can_fault(*k)) return true;
        }
        return false;
      default:
        return true;
    }
  }

  void expr(Program& p, const IExpr& e) {
    switch (e.op) {
      case IOp::kConst:
        return push_const(p, e.value);
      case IOp::kSignal:
        return p.emit(Op::kSignal, e.slot);
      case IOp::kField:
      case IOp::kLastField:
        p.emit(e.op == IOp::kField ? Op::kField : Op::kLastField, e.slot);
        if (e.scale != 1) {
          push_const(p, e.scale);
          p.emit(Op::kMul);
        }
        return;
      case IOp::kSinceLast:
        return p.emit(Op::kSinceLast);
      case IOp::kIndex:
        return p.emit(Op::kIndex);
      case IOp::kJobCount:
        return p.emit(Op::kJobCount);
      case IOp::kLastOr: {
        const int use_default = p.new_label(), done = p.new_label();
        p.emit(Op::kHasLast);
        p.jump(Op::kJumpIfZero, use_default);
        expr(p, *e.kids[0]);
        p.jump(Op::kJump, done);
        p.bind(use_default);
        expr(p, *e.kids[1]);
        p.bind(done);
        return;
      }
      default:
        break;
    }
    for (const auto& k : e.kids) expr(p, *k);
    static const std::map<IOp, Op> kOps = {
        {IOp::kNeg, Op::kNeg}, {IOp::kNot, Op::kNot}, {IOp::kAbs, Op::kAbs}, {IOp::kAdd, Op::kAdd},
        {IOp::kSub, Op::kSub}, {IOp::kMul, Op::kMul}, {IOp::kDiv, Op::kDiv}, {IOp::kMod, Op::kMod},
        {IOp::kMin, Op::kMin}, {IOp::kMax, Op::kMax}, {IOp::kEq, Op::kEq},   {IOp::kNe, Op::kNe},
        {IOp::kLt, Op::kLt},   {IOp::kLe, Op::kLe},   {IOp::kGt, Op::kGt},   {IOp::kGe, Op::kGe},
        {IOp::kAnd, Op::kAnd}, {IOp::kOr, Op::kOr}};
    p.emit(kOps.at(e.op));
  }

  // Pushes a value for field `f`, converted from microseconds to its unit.
  void field_value(Program& p, const IExpr& v, const devices::FieldSpec& f) {
    const int64_t scale = unit_scale(f);
    if (v.is_const()) return push_const(p, v.value / scale);
    expr(p, v);
    if (scale != 1) {
      push_const(p, scale);
      p.emit(Op::kDiv);
    }
  }

  void lower_signal(size_t i) {
    const Signal& s = p_.signals[i];
    image::Named<core::SignalRecord> rec;
    rec.name = s.name;
    if (s.raw) {
      const Device& d = p_.devices[s.device];
      const devices::FieldSpec& f = d.profile.sample_fields[s.sample_field];
      rec.record.kind = core::SignalKind::kRaw;
      rec.record.device = s.device;
      rec.record.field = f.geometry;
      rec.record.field.name = 0;
      rec.record.valid_min = static_cast<int32_t>(std::clamp<int64_t>(
          f.min, std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max()));
      rec.record.valid_max = static_cast<int32_t>(std::clamp<int64_t>(
          f.max, std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max()));
    } else {
      Program p;
      expr(p, *s.value);
      p.emit(Op::kReturn);
      rec.record.kind = core::SignalKind::kDerived;
      rec.record.device = core::kNone;
      place(p, rec.record.code_first, rec.record.code_len, s.span);
    }
    m_.signals.push_back(rec);
  }

  void place(Program& p, uint16_t& first, uint16_t& len, Span at) {
    std::vector<Insn> code = p.finish();
    if (code.size() > core::kMaxProgramLength) {
      diags_.emit(DiagKind::kTooMany, at, code.size(), "instructions in one program",
                  core::kMaxProgramLength);
      failed_ = true;
    }
    first = static_cast<uint16_t>(std::min<size_t>(m_.code.size(), 0xFFFF));
    len = static_cast<uint16_t>(std::min<size_t>(code.size(), 0xFFFF));
    m_.code.insert(m_.code.end(), code.begin(), code.end());
  }

  // Static part of a response: (response, errno, template).
  void static_response(size_t device, const Response& r, core::Response& response, uint8_t& err,
                       uint16_t& tmpl) {
    tmpl = core::kNone;
    err = 0;
    switch (r.kind) {
      case ResponseKind::kIgnore:
      case ResponseKind::kFailsafeExpected:
      case ResponseKind::kFailsafeComputed:
        response = core::Response::kIgnore;
        return;
      case ResponseKind::kReject:
        response = core::Response::kReject;
        err = r.reply_errno;
        return;
      case ResponseKind::kFailsafeTemplate:
        response = core::Response::kFailsafe;
        tmpl = add_template(make_template(device, *r.command, false));
        return;
    }
  }

  void lower_rate(const RateLimit& rl) {
    image::Named<core::RateRecord> rec;
    rec.name = rl.name;
    rec.record.task = rl.task;
    rec.record.device = rl.device;
    rec.record.max_per_job = static_cast<uint16_t>(rl.count);
    rec.record.only_channel = rl.index ? static_cast<uint8_t>(*rl.index + 1) : 0;
    rec.record.commands = mask_of(globals(rl.device, rl.commands));
    static_response(rl.device, rl.response, rec.record.response, rec.record.reply_errno,
                    rec.record.template_id);
    m_.rates.push_back(rec);
  }

  // The fail path of an invariant whose response is computed (FAIL_SUBST) or static (FAIL).
  void fail_tail(Program& p, const Invariant& inv) {
    if (inv.response.kind != ResponseKind::kFailsafeComputed) {
      p.emit(Op::kFail);
      return;
    }
    const CommandValue& cv = *inv.response.command;
    const bool same = cv.command == core::kNone;
    p.emit(Op::kSubstBegin, same ? core::kNone : global(inv.device, cv.command));
    const uint16_t cmd_for_spec = same ? inv.commands[0] : cv.command;
    for (const FieldValue& f : cv.fields) {
      field_value(p, *f.value, field_spec(inv.device, cmd_for_spec, f.slot));
      p.emit(Op::kSubstField, f.slot);
    }
    p.emit(Op::kFailSubst);
  }

  // Pushes 1 if field `f` of the checked command satisfies the expectation.
  void field_match(Program& p, const FieldValue& f, const devices::FieldSpec& spec) {
    const int64_t scale = unit_scale(spec);
    auto load = [&] {
      p.emit(Op::kField, f.slot);
      if (scale != 1) {
        push_const(p, scale);
        p.emit(Op::kMul);
      }
    };
    if (f.value) {
      load();
      expr(p, *f.value);
      p.emit(Op::kEq);
    } else if (f.lo_value) {
      load();
      expr(p, *f.lo_value);
      p.emit(Op::kGe);
      load();
      expr(p, *f.hi_value);
      p.emit(Op::kLe);
      p.emit(Op::kAnd);
    } else {
      for (size_t i = 0; i < f.set.size(); ++i) {
        load();
        expr(p, *f.set[i]);
        p.emit(Op::kEq);
        if (i) p.emit(Op::kOr);
      }
    }
  }

  // Substitutes expected command `e`. `same`: the checked command is `e` itself
  // (ranges clamp its value; unconstrained fields keep it).
  void substitute_expected(Program& p, const Invariant& inv, const CommandValue& e, bool same) {
    const auto& spec = p_.devices[inv.device].profile.commands[e.command];
    p.emit(Op::kSubstBegin, global(inv.device, e.command));
    std::vector<bool> set(spec.fields.size(), false);
    for (const FieldValue& f : e.fields) {
      const devices::FieldSpec& fs = spec.fields[f.slot];
      set[f.slot] = true;
      if (f.value) {
        field_value(p, *f.value, fs);
      } else if (f.lo_value) {
        if (same) {
          p.emit(Op::kField, f.slot);
          field_value(p, *f.lo_value, fs);
          p.emit(Op::kMax);
          field_value(p, *f.hi_value, fs);
          p.emit(Op::kMin);
        } else {
          field_value(p, *f.lo_value, fs);
        }
      } else {
        field_value(p, *f.set[0], fs);
      }
      p.emit(Op::kSubstField, f.slot);
    }
    for (size_t s = 0; s < spec.fields.size(); ++s) {
      if (set[s]) continue;
      if (same) {
        p.emit(Op::kField, static_cast<uint16_t>(s));
      } else {
        push_const(p, std::clamp<int64_t>(0, spec.fields[s].min, spec.fields[s].max));
      }
      p.emit(Op::kSubstField, static_cast<uint16_t>(s));
    }
    p.emit(Op::kFailSubst);
  }

  void lower_invariant(const Invariant& inv) {
    Program p;
    const int pass = p.new_label();
    if (inv.index) {
      p.emit(Op::kIndex);
      push_const(p, *inv.index);
      p.emit(Op::kEq);
      p.jump(Op::kJumpIfZero, pass);
    }
    if (inv.when) jump_unless(p, *inv.when, pass);
    const bool expected = inv.response.kind == ResponseKind::kFailsafeExpected;
    const auto& cmds = p_.devices[inv.device].profile.commands;
    switch (inv.form) {
      case InvariantForm::kRequire: {
        const int fail = p.new_label();
        jump_unless(p, *inv.require, fail);
        p.emit(Op::kPass);
        p.bind(fail);
        fail_tail(p, inv);
        break;
      }
      case InvariantForm::kExpect: {
        for (const CommandValue& e : inv.expect) {
          const int next = p.new_label();
          const int mismatch = p.new_label();
          p.emit(Op::kCommand);
          push_const(p, global(inv.device, e.command));
          p.emit(Op::kEq);
          p.jump(Op::kJumpIfZero, next);
          if (e.index) {
            p.emit(Op::kIndex);
            push_const(p, *e.index);
            p.emit(Op::kEq);
            p.jump(Op::kJumpIfZero, mismatch);
          }
          for (const FieldValue& f : e.fields) {
            field_match(p, f, cmds[e.command].fields[f.slot]);
            p.jump(Op::kJumpIfZero, mismatch);
          }
          p.emit(Op::kPass);
          p.bind(mismatch);
          if (expected) {
            substitute_expected(p, inv, e, true);
          } else {
            fail_tail(p, inv);
          }
          p.bind(next);
        }
        // Another command of an expected command's group.
        for (const CommandValue& e : inv.expect) {
          const std::string& group = cmds[e.command].group;
          std::vector<uint16_t> others;
          for (uint16_t c : inv.commands) {
            if (c != e.command && cmds[c].group == group) others.push_back(c);
          }
          if (others.empty()) continue;
          const int skip = p.new_label();
          for (size_t i = 0; i < others.size(); ++i) {
            p.emit(Op::kCommand);
            push_const(p, global(inv.device, others[i]));
            p.emit(Op::kEq);
            if (i) p.emit(Op::kOr);
          }
          p.jump(Op::kJumpIfZero, skip);
          if (expected) {
            substitute_expected(p, inv, e, false);
          } else {
            fail_tail(p, inv);
          }
          p.bind(skip);
        }
        // A command of no expected group (selected explicitly): it is not expected.
        fail_tail(p, inv);
        break;
      }
      case InvariantForm::kSequence: {
        const size_t n = inv.sequence.size();
        for (size_t i = 0; i < n; ++i) {
          const int next = p.new_label();
          const int fail = p.new_label();
          p.emit(Op::kState);
          push_const(p, static_cast<int64_t>(i));
          p.emit(Op::kEq);
          p.jump(Op::kJumpIfZero, next);
          p.emit(Op::kField, inv.sequence_slot);
          push_const(p, inv.sequence[i]);
          p.emit(Op::kEq);
          p.jump(Op::kJumpIfZero, fail);
          push_const(p, static_cast<int64_t>((i + 1) % n));
          p.emit(Op::kSetState);
          p.emit(Op::kPass);
          p.bind(fail);
          if (expected) {
            p.emit(Op::kSubstBegin, core::kNone);
            push_const(p, inv.sequence[i]);
            p.emit(Op::kSubstField, inv.sequence_slot);
            push_const(p, static_cast<int64_t>((i + 1) % n));
            p.emit(Op::kSetState);
            p.emit(Op::kFailSubst);
          } else {
            fail_tail(p, inv);
          }
          p.bind(next);
        }
        p.emit(Op::kFail);  // a state word outside the sequence: fail closed
        break;
      }
    }
    p.bind(pass);
    p.emit(Op::kPass);
    image::Named<core::InvariantRecord> rec;
    rec.name = inv.name;
    rec.record.device = inv.device;
    rec.record.commands = mask_of(globals(inv.device, inv.commands));
    rec.record.scope = inv.form == InvariantForm::kSequence ? inv.scope : core::StateScope::kDevice;
    rec.record.after_safe = after_safe_state(inv);
    static_response(inv.device, inv.response, rec.record.response, rec.record.reply_errno,
                    rec.record.template_id);
    place(p, rec.record.code_first, rec.record.code_len, inv.span);
    m_.invariants.push_back(rec);
  }

  // Same bound as the verifier's: per command, the invariants that apply to
  // it plus every derived-signal program.
  uint32_t estimate_cost() const {
    uint32_t derived = 0;
    for (const auto& s : m_.signals) {
      if (s.record.kind == core::SignalKind::kDerived) {
        derived += s.record.code_len;
      }
    }
    uint32_t worst = 0;
    for (size_t c = 0; c < m_.commands.size(); ++c) {
      uint32_t sum = 0;
      for (const auto& inv : m_.invariants) {
        if (inv.record.commands.bits[c / 32] & (1u << (c % 32))) sum += inv.record.code_len;
      }
      worst = std::max(worst, sum);
    }
    return worst + derived;
  }

  const CheckedPolicy& p_;
  DiagnosticEmitter& diags_;
  image::ImageModel m_;
  bool failed_ = false;
};

}  // namespace

LowerResult lower(const CheckedPolicy& policy, DiagnosticEmitter& diags) {
  return Lowerer(policy, diags).run();
}

}  // namespace contego::policy
