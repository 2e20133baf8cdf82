#include "policy/check/context.h"

namespace contego::policy::check_internal {

IExprPtr Sema::resolve(const ast::Expr& e, const Ctx& c) {
  switch (e.kind) {
    case ExprKind::kInt:
      return make_const(e.value, Type::kInt, e.span);
    case ExprKind::kDuration:
      return make_const(e.value, Type::kDuration, e.span);
    case ExprKind::kName:
      return resolve_name(e, c);
    case ExprKind::kMember: {
      auto r = resolve_member(e, c);
      if (!r) return error_expr(e.span);
      if (r->size() != 1) {
        diags_.emit(DiagKind::kTypeMismatch, e.span, "`" + source_text(e.span) + "`",
                    "a list of sensor values",
                    "one value; write e.g. `" + source_text(e.span) + "0`");
        return error_expr(e.span);
      }
      return signal_ref((*r)[0], e.span, c);
    }
    case ExprKind::kIndex: {
      auto list = resolve_list_signal(*e.kids[0], c);
      if (!list) return error_expr(e.span);
      auto idx = int_in(*e.kids[1], "the index", 0, static_cast<int64_t>(list->size()) - 1);
      if (!idx) return error_expr(e.span);
      return signal_ref((*list)[static_cast<size_t>(*idx)], e.span, c);
    }
    case ExprKind::kCall:
      return resolve_call(e, c);
    case ExprKind::kUnary: {
      IExprPtr a = resolve(*e.kids[0], c);
      if (a->type == Type::kError) return a;
      if (e.name == "not") {
        if (a->type != Type::kBool) {
          diags_.emit(DiagKind::kOperandMismatch, e.span, "not", type_phrase(a->type),
                      "nothing else", "a boolean");
          return error_expr(e.span);
        }
        return fold(IOp::kNot, Type::kBool, {a}, e.span);
      }
      if (!numeric(a->type)) {
        diags_.emit(DiagKind::kOperandMismatch, e.span, "-", type_phrase(a->type), "nothing else",
                    "a number or a duration");
        return error_expr(e.span);
      }
      return fold(IOp::kNeg, a->type, {a}, e.span);
    }
    case ExprKind::kBinary:
      return resolve_binary(e, c);
    case ExprKind::kIn:
      return resolve_in(e, c);
    case ExprKind::kRange:
    case ExprKind::kSet:
    case ExprKind::kList:
      diags_.emit(DiagKind::kTypeMismatch, e.span, c.what,
                  e.kind == ExprKind::kRange ? "a range"
                  : e.kind == ExprKind::kSet ? "a set"
                                             : "a list",
                  "a single value (ranges and sets belong after `in`)");
      return error_expr(e.span);
    case ExprKind::kError:
      return error_expr(e.span);
  }
  return error_expr(e.span);
}

std::string Sema::source_text(Span s) const {
  return std::string(source_.text().substr(s.begin, s.end - s.begin));
}

IExprPtr Sema::signal_ref(uint16_t id, Span span, const Ctx& c) {
  Signal& s = out_.signals[id];
  if (!c.signals || c.constant) {
    diags_.emit(DiagKind::kNotConstant, span, c.what, "signal `" + s.name + "`");
    return error_expr(span);
  }
  if (id >= c.signal_limit && !s.raw) {
    diags_.emit(DiagKind::kSignalCycle, span, s.name);
    return error_expr(span);
  }
  s.used = true;
  auto e = std::make_shared<IExpr>();
  e->op = IOp::kSignal;
  e->type = s.type;
  e->slot = id;
  e->lo = s.lo;
  e->hi = s.hi;
  e->span = span;
  return e;
}

// A field of the checked command: same slot and scale in every command of the rule.
IExprPtr Sema::field_ref(const std::string& name, Span span, const Ctx& c, IOp op) {
  const auto& cmds = c.device->profile.commands;
  std::optional<uint8_t> slot;
  const devices::FieldSpec* spec = nullptr;
  bool shared = true;
  for (uint16_t ci : *c.commands) {
    const auto& fields = cmds[ci].fields;
    auto it = std::find_if(fields.begin(), fields.end(),
                           [&](const devices::FieldSpec& f) { return f.name == name; });
    if (it == fields.end()) {
      shared = false;
      continue;
    }
    const auto s = static_cast<uint8_t>(it - fields.begin());
    if (slot && *slot != s) shared = false;
    if (spec && time_unit_scale(spec->unit) != time_unit_scale(it->unit)) shared = false;
    slot = s;
    spec = &*it;
  }
  if (!slot) return nullptr;
  if (!shared) {
    diags_.emit(DiagKind::kFieldNotShared, span, name, c.rule);
    return error_expr(span);
  }
  auto e = std::make_shared<IExpr>();
  e->op = op;
  e->slot = *slot;
  const int64_t scale = time_unit_scale(spec->unit);
  e->type = scale ? Type::kDuration : Type::kInt;
  e->scale = scale ? scale : 1;
  e->lo = sat(i128{spec->min} * e->scale);
  e->hi = sat(i128{spec->max} * e->scale);
  e->span = span;
  return e;
}

bool Sema::has_index(const Ctx& c) const {
  if (!c.device || !c.commands) return false;
  for (uint16_t ci : *c.commands) {
    if (c.device->profile.commands[ci].repeat > 1) return true;
  }
  return false;
}

IExprPtr Sema::resolve_name(const ast::Expr& e, const Ctx& c) {
  const std::string& n = e.name;
  const Sym* sym = lookup(n);
  if (c.device && c.commands && !c.constant) {
    if (IExprPtr f = field_ref(n, e.span, c, IOp::kField)) {
      if (sym && (sym->kind == SymKind::kSignal || sym->kind == SymKind::kConst)) {
        diags_.emit(DiagKind::kFieldShadowsSignal, e.span, n,
                    sym_phrase(sym->kind).substr(sym->kind == SymKind::kConst ? 2 : 2));
      }
      return f;
    }
    if ((n == "index" || n == "channel") && !sym && has_index(c)) {
      auto x = std::make_shared<IExpr>();
      x->op = IOp::kIndex;
      x->lo = 0;
      x->hi = 0;  // the channels the rule's commands have
      for (uint16_t ci : *c.commands) {
        x->hi = std::max<int64_t>(x->hi, c.device->profile.commands[ci].repeat - 1);
      }
      x->span = e.span;
      return x;
    }
  }
  if (!sym) {
    if (n == "true" || n == "false") return make_const(n == "true", Type::kBool, e.span);
    const bool later_signal =
        std::any_of(file_.signals.begin(), file_.signals.end(),
                    [&](const ast::SignalDecl& s) { return s.name.name == n; });
    if (later_signal && !c.constant) {
      diags_.emit(DiagKind::kSignalCycle, e.span, n);
      return error_expr(e.span);
    }
    std::string expected = c.constant ? "a constant"
                           : (c.device && c.commands)
                               ? "a constant, a signal or a field of the checked command"
                               : "a constant or a signal";
    diags_.emit(DiagKind::kUnknownName, e.span, n, expected);
    return error_expr(e.span);
  }
  switch (sym->kind) {
    case SymKind::kConst: {
      Const& k = consts_[sym->index];
      k.used = true;
      if (k.value->type == Type::kError) return k.value;
      auto copy = std::make_shared<IExpr>(*k.value);
      copy->span = e.span;
      return copy;
    }
    case SymKind::kSignal:
      if (out_.signals[sym->index].name != n) used_aliases_.insert(n);
      return signal_ref(static_cast<uint16_t>(sym->index), e.span, c);
    case SymKind::kListSignal:
      diags_.emit(DiagKind::kTypeMismatch, e.span, "`" + n + "`", "a list of signals",
                  "one value; write e.g. `" + n + "[0]`");
      return error_expr(e.span);
    default:
      diags_.emit(DiagKind::kTypeMismatch, e.span, "`" + n + "`", sym_phrase(sym->kind),
                  "a value (a constant, a signal or a field)");
      return error_expr(e.span);
  }
}

// `dev.value` → raw signal ids (one, or several for a list such as `line.raw`).
std::optional<std::vector<uint16_t>> Sema::resolve_member(const ast::Expr& e, const Ctx& c) {
  const ast::Expr& base = *e.kids[0];
  if (base.kind != ExprKind::kName) {
    diags_.emit(DiagKind::kExpectedToken, base.span, "a sensor name before `.`",
                "`" + source_text(base.span) + "`");
    return std::nullopt;
  }
  if (!lookup(base.name) && c.constant &&
      std::any_of(file_.devices.begin(), file_.devices.end(),
                  [&](const ast::DeviceDecl& d) { return d.name.name == base.name; })) {
    diags_.emit(DiagKind::kNotConstant, e.span, c.what, "sensor `" + base.name + "`");
    return std::nullopt;
  }
  const Sym* sym = lookup_as(base.name, base.span, SymKind::kDevice, "a sensor");
  if (!sym) return std::nullopt;
  const auto dev_id = static_cast<uint16_t>(sym->index);
  const Device& dev = out_.devices[dev_id];
  if (!(dev.role & core::kRoleSensor)) {
    diags_.emit(DiagKind::kNotASensor, base.span, base.name, "reading `" + e.name + "`");
    return std::nullopt;
  }
  if (c.constant || !c.signals) {
    diags_.emit(DiagKind::kNotConstant, e.span, c.what, "sensor `" + base.name + "`");
    return std::nullopt;
  }
  const auto& fields = dev.profile.sample_fields;
  std::vector<uint16_t> ids;
  for (size_t i = 0; i < fields.size(); ++i) {
    if (fields[i].name == e.name) return std::vector<uint16_t>{raw_signal(dev_id, i, e.span)};
  }
  // A list: name0, name1, ...
  for (size_t k = 0;; ++k) {
    auto it = std::find_if(fields.begin(), fields.end(), [&](const devices::FieldSpec& f) {
      return f.name == e.name + std::to_string(k);
    });
    if (it == fields.end()) break;
    ids.push_back(raw_signal(dev_id, static_cast<size_t>(it - fields.begin()), e.span));
  }
  if (!ids.empty()) return ids;
  std::vector<std::string> names;
  for (const auto& f : fields) names.push_back(f.name);
  diags_.emit(DiagKind::kUnknownSampleValue, e.name_span, base.name, e.name, join_names(names));
  return std::nullopt;
}

uint16_t Sema::raw_signal(uint16_t dev, size_t field, Span span) {
  for (size_t i = 0; i < out_.signals.size(); ++i) {
    const Signal& s = out_.signals[i];
    if (s.raw && s.device == dev && s.sample_field == field) return static_cast<uint16_t>(i);
  }
  const devices::FieldSpec& f = out_.devices[dev].profile.sample_fields[field];
  Signal s;
  s.name = out_.devices[dev].name + "." + f.name;
  s.span = span;
  s.raw = true;
  s.device = dev;
  s.sample_field = static_cast<uint16_t>(field);
  s.type = Type::kInt;
  s.lo = f.min;
  s.hi = f.max;
  s.implicit = true;
  s.used = true;
  out_.signals.push_back(s);
  return static_cast<uint16_t>(out_.signals.size() - 1);
}

std::optional<std::vector<uint16_t>> Sema::resolve_list_signal(const ast::Expr& e, const Ctx& c) {
  if (e.kind == ExprKind::kMember) return resolve_member(e, c);
  if (e.kind == ExprKind::kName) {
    const Sym* sym = lookup(e.name);
    if (sym && sym->kind == SymKind::kListSignal) {
      std::vector<uint16_t> ids = list_signals_[sym->index];
      for (uint16_t id : ids) out_.signals[id].used = true;
      return ids;
    }
    if (!sym) {
      diags_.emit(DiagKind::kUnknownName, e.span, e.name, "a list of sensor values");
      return std::nullopt;
    }
  }
  diags_.emit(DiagKind::kTypeMismatch, e.span, "`" + source_text(e.span) + "`", "not a list",
              "a list of sensor values such as `line.raw`");
  return std::nullopt;
}

std::optional<std::vector<int64_t>> Sema::const_list(const ast::Expr& e, const std::string& what) {
  if (e.kind != ExprKind::kList) {
    diags_.emit(DiagKind::kTypeMismatch, e.span, what, "not a list",
                "a list of numbers such as `[1, 2, 3]`");
    return std::nullopt;
  }
  std::vector<int64_t> out;
  bool ok = true;
  for (const auto& k : e.kids) {
    auto v = const_value(*k, Type::kInt, what);
    if (!v) ok = false;
    out.push_back(v.value_or(0));
  }
  if (!ok) return std::nullopt;
  return out;
}

IExprPtr Sema::resolve_call(const ast::Expr& e, const Ctx& c) {
  const std::string& f = e.name;
  auto positional = [&](size_t n, const char* shape) -> bool {
    for (size_t i = 0; i < e.arg_names.size(); ++i) {
      if (!e.arg_names[i].empty()) {
        diags_.emit(DiagKind::kArgumentCount, e.arg_name_spans[i], f, shape,
                    "a named argument `" + e.arg_names[i] + "`");
        return false;
      }
    }
    if (e.kids.size() != n && n != SIZE_MAX) {
      diags_.emit(DiagKind::kArgumentCount, e.span, f, shape,
                  std::to_string(e.kids.size()) + " arguments");
      return false;
    }
    return true;
  };
  auto resolve_args = [&](std::vector<IExprPtr>& args) -> bool {
    for (const auto& k : e.kids) {
      args.push_back(resolve(*k, c));
      if (args.back()->type == Type::kError) return false;
      if (!numeric(args.back()->type)) {
        diags_.emit(DiagKind::kTypeMismatch, k->span, "an argument of `" + f + "`",
                    type_phrase(args.back()->type), "a number or a duration");
        return false;
      }
    }
    for (size_t i = 1; i < args.size(); ++i) {
      if (args[i]->type != args[0]->type) {
        diags_.emit(DiagKind::kOperandMismatch, e.kids[i]->span, f, type_phrase(args[0]->type),
                    type_phrase(args[i]->type), "arguments of one kind");
        return false;
      }
    }
    return true;
  };
  if (f == "abs") {
    std::vector<IExprPtr> args;
    if (!positional(1, "one argument") || !resolve_args(args)) return error_expr(e.span);
    return fold(IOp::kAbs, args[0]->type, args, e.span);
  }
  if (f == "min" || f == "max") {
    std::vector<IExprPtr> args;
    if (!positional(SIZE_MAX, "two or more arguments") || !resolve_args(args)) {
      return error_expr(e.span);
    }
    if (args.size() < 2) {
      diags_.emit(DiagKind::kArgumentCount, e.span, f, "two or more arguments",
                  std::to_string(args.size()));
      return error_expr(e.span);
    }
    IExprPtr acc = args[0];
    for (size_t i = 1; i < args.size(); ++i) {
      acc = fold(f == "min" ? IOp::kMin : IOp::kMax, acc->type, {acc, args[i]}, e.span);
    }
    return acc;
  }
  if (f == "clamp") {
    std::vector<IExprPtr> args;
    if (!positional(3, "three arguments (value, low, high)") || !resolve_args(args)) {
      return error_expr(e.span);
    }
    IExprPtr lo = fold(IOp::kMax, args[0]->type, {args[0], args[1]}, e.span);
    return fold(IOp::kMin, args[0]->type, {lo, args[2]}, e.span);
  }
  if (f == "last" || f == "since_last") return resolve_history(e, c, positional);
  if (f == "line_position") return resolve_line_position(e, c);
  diags_.emit(DiagKind::kUnknownFunction, e.name_span, f);
  return error_expr(e.span);
}

// `last(field [, default])` and `since_last([default])`: the history of this
// command kind and channel. Without a default, reading it before the first
// command reached the device faults (fails closed); with one, the default
// is used instead (lowered behind HAS_LAST).
template <typename Positional>
IExprPtr Sema::resolve_history(const ast::Expr& e, const Ctx& c, Positional& positional) {
  const bool last = e.name == "last";
  const size_t required = last ? 1 : 0;
  const bool with_default = e.kids.size() == required + 1;
  if (!positional(
          with_default ? required + 1 : required,
          last ? "a field name and an optional default" : "no arguments or a default duration")) {
    return error_expr(e.span);
  }
  if (!c.device || !c.commands || c.constant) {
    diags_.emit(DiagKind::kNotConstant, e.span, c.what, "the command history");
    return error_expr(e.span);
  }
  IExprPtr r;
  if (!last) {
    auto x = std::make_shared<IExpr>();
    x->op = IOp::kSinceLast;
    x->type = Type::kDuration;
    x->lo = 0;
    x->span = e.span;
    r = x;
  } else {
    const ast::Expr& a = *e.kids[0];
    if (a.kind != ExprKind::kName) {
      diags_.emit(DiagKind::kExpectedToken, a.span, "a field name",
                  "`" + source_text(a.span) + "`");
      return error_expr(e.span);
    }
    r = field_ref(a.name, a.span, c, IOp::kLastField);
    if (!r) {
      unknown_field(a.name, a.span, *c.device, (*c.commands)[0]);
      return error_expr(e.span);
    }
    if (r->type == Type::kError) return r;
  }
  if (!with_default) return r;
  IExprPtr d = resolve(*e.kids[required], c);
  if (d->type == Type::kError) return d;
  if (d->type != r->type) {
    diags_.emit(DiagKind::kTypeMismatch, e.kids[required]->span, "the default of `" + e.name + "`",
                type_phrase(d->type), type_phrase(r->type));
    return error_expr(e.span);
  }
  auto x = std::make_shared<IExpr>();
  x->op = IOp::kLastOr;
  x->type = r->type;
  x->span = e.span;
  x->lo = std::min(r->lo, d->lo);
  x->hi = std::max(r->hi, d->hi);
  x->kids = {r, d};
  return x;
}

IExprPtr Sema::resolve_line_position(const ast::Expr& e, const Ctx& c) {
  const ast::Expr* list = nullptr;
  const ast::Expr *white = nullptr, *black = nullptr, *weights = nullptr;
  for (size_t i = 0; i < e.kids.size(); ++i) {
    const std::string& n = e.arg_names[i];
    if (n.empty() && !list) {
      list = e.kids[i].get();
    } else if (n == "white") {
      white = e.kids[i].get();
    } else if (n == "black") {
      black = e.kids[i].get();
    } else if (n == "weights") {
      weights = e.kids[i].get();
    } else {
      diags_.emit(DiagKind::kArgumentCount, n.empty() ? e.kids[i]->span : e.arg_name_spans[i],
                  "line_position", "a list of sensor values, `white=`, `black=` and `weights=`",
                  n.empty() ? "an extra value" : "`" + n + "=`");
      return error_expr(e.span);
    }
  }
  if (!list || !white || !black || !weights) {
    diags_.emit(DiagKind::kArgumentCount, e.span, "line_position",
                "a list of sensor values, `white=`, `black=` and `weights=`",
                std::to_string(e.kids.size()) + " arguments");
    return error_expr(e.span);
  }
  auto ids = resolve_list_signal(*list, c);
  auto w = const_list(*white, "`white`");
  auto b = const_list(*black, "`black`");
  auto m = const_list(*weights, "`weights`");
  if (!ids || !w || !b || !m) return error_expr(e.span);
  const size_t n = ids->size();
  bool ok = true;
  auto check_len = [&](const std::vector<int64_t>& v, const ast::Expr& at, const char* name) {
    if (v.size() != n) {
      diags_.emit(DiagKind::kListLength, at.span, name, v.size(), n);
      ok = false;
    }
  };
  check_len(*w, *white, "white");
  check_len(*b, *black, "black");
  check_len(*m, *weights, "weights");
  if (!ok) return error_expr(e.span);
  IExprPtr sum;
  for (size_t i = 0; i < n; ++i) {
    if ((*b)[i] == (*w)[i]) {
      diags_.emit(DiagKind::kConstantOverflow, black->kids[i]->span,
                  "black and white calibration are equal: division by zero");
      return error_expr(e.span);
    }
    IExprPtr raw = signal_ref((*ids)[i], list->span, c);
    if (raw->type == Type::kError) return raw;
    IExprPtr t =
        fold(IOp::kSub, Type::kInt, {raw, make_const((*w)[i], Type::kInt, e.span)}, e.span);
    t = fold(IOp::kMul, Type::kInt, {t, make_const(100 * kLineScale, Type::kInt, e.span)}, e.span);
    t = fold(IOp::kDiv, Type::kInt, {t, make_const((*b)[i] - (*w)[i], Type::kInt, e.span)}, e.span);
    t = fold(IOp::kMul, Type::kInt, {t, make_const((*m)[i], Type::kInt, e.span)}, e.span);
    sum = sum ? fold(IOp::kAdd, Type::kInt, {sum, t}, e.span) : t;
  }
  if (!sum) return make_const(0, Type::kInt, e.span);
  return fold(IOp::kDiv, Type::kInt, {sum, make_const(kLineScale, Type::kInt, e.span)}, e.span);
}

IExprPtr Sema::resolve_binary(const ast::Expr& e, const Ctx& c) {
  IExprPtr a = resolve(*e.kids[0], c);
  IExprPtr b = resolve(*e.kids[1], c);
  if (a->type == Type::kError || b->type == Type::kError) return error_expr(e.span);
  const std::string& op = e.name;
  auto mismatch = [&](const char* expected) {
    diags_.emit(DiagKind::kOperandMismatch, e.span, op, type_phrase(a->type), type_phrase(b->type),
                expected);
    return error_expr(e.span);
  };
  if (op == "and" || op == "or") {
    if (a->type != Type::kBool || b->type != Type::kBool) return mismatch("two booleans");
    return fold(op == "and" ? IOp::kAnd : IOp::kOr, Type::kBool, {a, b}, e.span);
  }
  static const std::map<std::string, IOp> kCmp = {{"==", IOp::kEq}, {"!=", IOp::kNe},
                                                  {"<", IOp::kLt},  {"<=", IOp::kLe},
                                                  {">", IOp::kGt},  {">=", IOp::kGe}};
  if (auto it = kCmp.find(op); it != kCmp.end()) {
    if (a->type != b->type) return mismatch("two values of the same kind");
    if (a->type == Type::kBool && op != "==" && op != "!=") {
      return mismatch("two numbers or two durations");
    }
    return fold(it->second, Type::kBool, {a, b}, e.span);
  }
  if (!numeric(a->type) || !numeric(b->type)) return mismatch("numbers or durations");
  const bool ad = a->type == Type::kDuration, bd = b->type == Type::kDuration;
  if (op == "+" || op == "-") {
    if (ad != bd) return mismatch("two numbers or two durations");
    return fold(op == "+" ? IOp::kAdd : IOp::kSub, a->type, {a, b}, e.span);
  }
  if (op == "*") {
    if (ad && bd) return mismatch("a duration and a number");
    return fold(IOp::kMul, (ad || bd) ? Type::kDuration : Type::kInt, {a, b}, e.span);
  }
  if (op == "/") {
    if (!ad && bd) return mismatch("a duration divided by a number or by a duration");
    return fold(IOp::kDiv, (ad && !bd) ? Type::kDuration : Type::kInt, {a, b}, e.span);
  }
  if (ad != bd) return mismatch("two numbers or two durations");
  return fold(IOp::kMod, a->type, {a, b}, e.span);
}

IExprPtr Sema::resolve_in(const ast::Expr& e, const Ctx& c) {
  IExprPtr x = resolve(*e.kids[0], c);
  const ast::Expr& r = *e.kids[1];
  if (x->type == Type::kError) return x;
  if (!numeric(x->type)) {
    diags_.emit(DiagKind::kOperandMismatch, e.span, "in", type_phrase(x->type), "a range",
                "a number or a duration on the left");
    return error_expr(e.span);
  }
  IExprPtr result;
  if (r.kind == ExprKind::kRange) {
    IExprPtr lo = resolve(*r.kids[0], c), hi = resolve(*r.kids[1], c);
    if (lo->type == Type::kError || hi->type == Type::kError) return error_expr(e.span);
    if (lo->type != x->type || hi->type != x->type) {
      diags_.emit(DiagKind::kOperandMismatch, e.span, "in", type_phrase(x->type),
                  type_phrase(lo->type != x->type ? lo->type : hi->type),
                  "a range of the same kind as the value");
      return error_expr(e.span);
    }
    if (lo->is_const() && hi->is_const() && lo->value > hi->value) {
      diags_.emit(DiagKind::kEmptyRange, r.span, lo->value, hi->value);
      return error_expr(e.span);
    }
    // The halves are not reported on their own (`index in 0..1`: `index >= 0`
    // always holds, the range does not): the range as a whole is.
    quiet_comparisons_ = true;
    result = fold(IOp::kAnd, Type::kBool,
                  {fold(IOp::kGe, Type::kBool, {x, lo}, e.span),
                   fold(IOp::kLe, Type::kBool, {x, hi}, e.span)},
                  e.span);
    quiet_comparisons_ = false;
    std::optional<bool> decided;
    if (x->lo != kMin && x->hi != kMax && lo->is_const() && hi->is_const()) {
      if (x->lo >= lo->value && x->hi <= hi->value) decided = true;
      if (x->hi < lo->value || x->lo > hi->value) decided = false;
    }
    if (decided && !x->is_const()) {
      diags_.emit(DiagKind::kImpossibleComparison, e.span, source_text(e.span),
                  *decided != e.negated ? "true" : "false",
                  fmt::format("the value is within {}..{} and the range is {}..{}", x->lo, x->hi,
                              lo->value, hi->value));
      auto whole = std::make_shared<IExpr>(*result);
      whole->lo = whole->hi = *decided ? 1 : 0;
      result = whole;
    }
  } else if (r.kind == ExprKind::kSet) {
    for (const auto& k : r.kids) {
      IExprPtr v = resolve(*k, c);
      if (v->type == Type::kError) return v;
      if (v->type != x->type) {
        diags_.emit(DiagKind::kOperandMismatch, e.span, "in", type_phrase(x->type),
                    type_phrase(v->type), "a set of the same kind as the value");
        return error_expr(e.span);
      }
      quiet_comparisons_ = true;  // one member out of reach does not decide the set
      IExprPtr eq = fold(IOp::kEq, Type::kBool, {x, v}, e.span);
      result = result ? fold(IOp::kOr, Type::kBool, {result, eq}, e.span) : eq;
      quiet_comparisons_ = false;
    }
    if (result && result->lo == 0 && result->hi == 0 && !x->is_const() && !result->is_const()) {
      diags_.emit(
          DiagKind::kImpossibleComparison, e.span, source_text(e.span),
          e.negated ? "true" : "false",
          fmt::format("the value is within {}..{} and no member of the set is", x->lo, x->hi));
    }
    if (!result) result = make_const(0, Type::kBool, e.span);
  } else {
    return error_expr(e.span);
  }
  if (e.negated) result = fold(IOp::kNot, Type::kBool, {result}, e.span);
  return result;
}

}  // namespace contego::policy::check_internal
