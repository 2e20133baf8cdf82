#include "policy/check/check.h"

#include <algorithm>
#include <limits>
#include <map>
#include <set>

#include "contego/core/limits.h"

namespace contego::policy {
namespace {

__extension__ typedef __int128 i128;  // exact intermediate arithmetic

using ast::ExprKind;

constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
constexpr int64_t kMax = std::numeric_limits<int64_t>::max();

int64_t sat(i128 v) {
  if (v > kMax) return kMax;
  if (v < kMin) return kMin;
  return static_cast<int64_t>(v);
}

std::string join_names(const std::vector<std::string>& names) {
  if (names.empty()) return "(none)";
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (i) out += ", ";
    out += "`" + names[i] + "`";
  }
  return out;
}

int64_t time_unit_scale(const std::string& unit) {
  if (unit == "us") return 1;
  if (unit == "ms") return 1000;
  if (unit == "s") return 1000000;
  return 0;
}

struct Errno {
  const char* name;
  uint8_t value;
};
constexpr Errno kErrnos[] = {{"EPERM", 1},   {"EIO", 5},    {"ENXIO", 6},   {"EAGAIN", 11},
                             {"EACCES", 13}, {"EBUSY", 16}, {"EINVAL", 22}, {"EREMOTEIO", 121}};

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

class Sema {
 public:
  Sema(const ast::File& file, const SourceBuffer& source, DiagnosticEmitter& diags,
       const ProfileLookup& profiles)
      : file_(file), source_(source), diags_(diags), profiles_(profiles) {}

  CheckedPolicy run() {
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

 private:
  enum class SymKind { kConst, kDevice, kSignal, kListSignal, kTask, kInvariant };
  struct Sym {
    SymKind kind;
    size_t index;
    Span span;
  };
  struct Const {
    std::string name;
    Span span;
    IExprPtr value;
    bool used = false;
  };

  // Context for resolving an expression.
  struct Ctx {
    std::string what;                // "the condition of `INV1`" (for messages)
    bool constant = false;           // must fold to a constant
    bool signals = true;             // may read signals
    const Device* device = nullptr;  // fields of the checked command
    const std::vector<uint16_t>* commands = nullptr;
    size_t signal_limit = SIZE_MAX;  // derived signals may read only earlier ones
    std::string rule;                // rule text for FieldNotShared
  };

  static std::string sym_phrase(SymKind k) {
    switch (k) {
      case SymKind::kConst:
        return "a constant";
      case SymKind::kDevice:
        return "a device";
      case SymKind::kSignal:
        return "a signal";
      case SymKind::kListSignal:
        return "a list signal";
      case SymKind::kTask:
        return "a task";
      case SymKind::kInvariant:
        return "an invariant";
    }
    return "a name";
  }

  bool declare(const std::string& name, SymKind kind, size_t index, Span span) {
    auto [it, inserted] = names_.emplace(name, Sym{kind, index, span});
    if (!inserted) {
      diags_.emit(DiagKind::kDuplicateName, span, name, sym_phrase(it->second.kind));
      diags_.note(DiagKind::kPreviousDeclaration, it->second.span, name);
      return false;
    }
    return true;
  }
  const Sym* lookup(const std::string& name) const {
    auto it = names_.find(name);
    return it == names_.end() ? nullptr : &it->second;
  }

  // --- constants and expressions -------------------------------------------
  static IExprPtr make_const(int64_t v, Type t, Span span) {
    auto e = std::make_shared<IExpr>();
    e->op = IOp::kConst;
    e->type = t;
    e->value = v;
    e->lo = e->hi = v;
    e->span = span;
    return e;
  }
  static IExprPtr error_expr(Span span) {
    auto e = std::make_shared<IExpr>();
    e->type = Type::kError;
    e->span = span;
    return e;
  }

  void declare_const(const ast::ConstDecl& c) {
    Ctx ctx;
    ctx.what = "constant `" + c.name.name + "`";
    ctx.constant = true;
    ctx.signals = false;
    IExprPtr v = resolve(*c.value, ctx);
    if (!declare(c.name.name, SymKind::kConst, consts_.size(), c.name.span)) return;
    consts_.push_back(Const{c.name.name, c.name.span, v});
  }

  // Evaluates a constant expression of the given type; reports problems.
  std::optional<int64_t> const_value(const ast::Expr& e, Type want, const std::string& what) {
    Ctx ctx;
    ctx.what = what;
    ctx.constant = true;
    ctx.signals = false;
    IExprPtr v = resolve(e, ctx);
    if (v->type == Type::kError) return std::nullopt;
    if (v->type != want) {
      diags_.emit(
          DiagKind::kTypeMismatch, e.span, what, type_phrase(v->type),
          want == Type::kDuration ? "a duration such as `200ms`" : std::string(type_phrase(want)));
      return std::nullopt;
    }
    if (!v->is_const()) return std::nullopt;
    return v->value;
  }
  uint32_t duration_us(const ast::Expr& e, const std::string& what) {
    auto v = const_value(e, Type::kDuration, what);
    if (!v) return 0;
    if (*v < 0 || *v > std::numeric_limits<uint32_t>::max()) {
      diags_.emit(DiagKind::kValueOutOfRange, e.span, what, std::to_string(*v) + "us", "a duration",
                  "0us", std::to_string(std::numeric_limits<uint32_t>::max()) + "us");
      return 0;
    }
    return static_cast<uint32_t>(*v);
  }
  uint32_t duration_ns(const ast::Expr& e, const std::string& what) {
    auto v = const_value(e, Type::kDuration, what);
    if (!v) return 0;
    const int64_t ns = *v * 1000;
    if (*v < 0 || ns > std::numeric_limits<uint32_t>::max()) {
      diags_.emit(DiagKind::kValueOutOfRange, e.span, what, std::to_string(*v) + "us",
                  "a per-check overhead", "0us", "4294967us");
      return 0;
    }
    return static_cast<uint32_t>(ns);
  }
  std::optional<int64_t> int_in(const ast::Expr& e, const std::string& what, int64_t lo,
                                int64_t hi) {
    auto v = const_value(e, Type::kInt, what);
    if (!v) return std::nullopt;
    if (*v < lo || *v > hi) {
      diags_.emit(DiagKind::kValueOutOfRange, e.span, what, *v, what, lo, hi);
      return std::nullopt;
    }
    return v;
  }

  IExprPtr fold(IOp op, Type type, std::vector<IExprPtr> kids, Span span) {
    auto e = std::make_shared<IExpr>();
    e->op = op;
    e->type = type;
    e->span = span;
    e->kids = std::move(kids);
    bool all_const = true;
    for (const auto& k : e->kids) all_const = all_const && k->is_const();
    const IExpr* a = e->kids.size() > 0 ? e->kids[0].get() : nullptr;
    const IExpr* b = e->kids.size() > 1 ? e->kids[1].get() : nullptr;
    // Intervals (saturating; booleans are 0..1).
    i128 lo = kMin, hi = kMax;
    auto ab = [&](auto f) {
      i128 c[4] = {f(i128{a->lo}, i128{b->lo}), f(i128{a->lo}, i128{b->hi}),
                   f(i128{a->hi}, i128{b->lo}), f(i128{a->hi}, i128{b->hi})};
      lo = *std::min_element(c, c + 4);
      hi = *std::max_element(c, c + 4);
    };
    const bool bounded_a = a && a->lo != kMin && a->hi != kMax;
    const bool bounded_b = b && b->lo != kMin && b->hi != kMax;
    switch (op) {
      case IOp::kNeg:
        if (bounded_a) lo = -i128{a->hi}, hi = -i128{a->lo};
        break;
      case IOp::kAbs:
        if (bounded_a) {
          hi = std::max(-i128{a->lo}, i128{a->hi});
          lo = (a->lo <= 0 && a->hi >= 0)
                   ? 0
                   : std::min(-i128{a->hi}, i128{a->lo} < 0 ? -i128{a->hi} : i128{a->lo});
          if (a->lo >= 0) lo = a->lo;
          if (a->hi <= 0) lo = -i128{a->hi};
        }
        break;
      case IOp::kAdd:
        if (bounded_a && bounded_b) ab([](i128 x, i128 y) { return x + y; });
        break;
      case IOp::kSub:
        if (bounded_a && bounded_b) ab([](i128 x, i128 y) { return x - y; });
        break;
      case IOp::kMul:
        if (bounded_a && bounded_b) ab([](i128 x, i128 y) { return x * y; });
        break;
      case IOp::kDiv:
        if (bounded_a && bounded_b && (b->lo > 0 || b->hi < 0)) {
          ab([](i128 x, i128 y) { return x / y; });
        }
        break;
      case IOp::kMin:
        if (bounded_a && bounded_b) lo = std::min(a->lo, b->lo), hi = std::min(a->hi, b->hi);
        break;
      case IOp::kMax:
        if (bounded_a && bounded_b) lo = std::max(a->lo, b->lo), hi = std::max(a->hi, b->hi);
        break;
      case IOp::kMod:
        if (bounded_b) {
          const i128 m = std::max(i128{b->hi}, -i128{b->lo}) - 1;
          lo = (a && a->lo >= 0) ? 0 : -m;
          hi = (a && a->hi <= 0) ? 0 : m;
        }
        break;
      default:
        break;
    }
    if (type == Type::kBool) lo = 0, hi = 1;
    e->lo = sat(lo);
    e->hi = sat(hi);
    // Comparisons decided by the intervals alone.
    std::optional<bool> decided;
    if (a && b &&
        (op == IOp::kLt || op == IOp::kLe || op == IOp::kGt || op == IOp::kGe || op == IOp::kEq ||
         op == IOp::kNe)) {
      const bool known = a->lo != kMin || a->hi != kMax;
      const bool known_b = b->lo != kMin || b->hi != kMax;
      if (known && known_b) {
        switch (op) {
          case IOp::kLt:
            if (a->hi < b->lo) decided = true;
            if (a->lo >= b->hi) decided = false;
            break;
          case IOp::kLe:
            if (a->hi <= b->lo) decided = true;
            if (a->lo > b->hi) decided = false;
            break;
          case IOp::kGt:
            if (a->lo > b->hi) decided = true;
            if (a->hi <= b->lo) decided = false;
            break;
          case IOp::kGe:
            if (a->lo >= b->hi) decided = true;
            if (a->hi < b->lo) decided = false;
            break;
          case IOp::kEq:
            if (a->hi < b->lo || a->lo > b->hi) decided = false;
            break;
          case IOp::kNe:
            if (a->hi < b->lo || a->lo > b->hi) decided = true;
            break;
          default:
            break;
        }
      }
      if (decided && !all_const && !quiet_comparisons_) {
        diags_.emit(DiagKind::kImpossibleComparison, span,
                    std::string(source_.text().substr(span.begin, span.end - span.begin)),
                    *decided ? "true" : "false",
                    fmt::format("the left side is within {}..{} and the right side within {}..{}",
                                a->lo, a->hi, b->lo, b->hi));
      }
    }
    if (!all_const) {
      if (decided) {
        e->lo = e->hi = *decided ? 1 : 0;
      }
      if (op == IOp::kAnd &&
          ((a->is_const() && a->value == 0) || (b->is_const() && b->value == 0))) {
        e->lo = e->hi = 0;
      }
      if (op == IOp::kOr &&
          ((a->is_const() && a->value != 0) || (b->is_const() && b->value != 0))) {
        e->lo = e->hi = 1;
      }
      return e;
    }
    // Constant folding with checked arithmetic.
    const int64_t x = a ? a->value : 0;
    const int64_t y = b ? b->value : 0;
    int64_t r = 0;
    bool bad = false;
    switch (op) {
      case IOp::kNeg:
        bad = __builtin_sub_overflow(int64_t{0}, x, &r);
        break;
      case IOp::kNot:
        r = x == 0;
        break;
      case IOp::kAbs:
        bad = x == kMin;
        r = x < 0 ? -x : x;
        break;
      case IOp::kAdd:
        bad = __builtin_add_overflow(x, y, &r);
        break;
      case IOp::kSub:
        bad = __builtin_sub_overflow(x, y, &r);
        break;
      case IOp::kMul:
        bad = __builtin_mul_overflow(x, y, &r);
        break;
      case IOp::kDiv:
        bad = y == 0 || (x == kMin && y == -1);
        if (!bad) r = x / y;
        break;
      case IOp::kMod:
        bad = y == 0 || (x == kMin && y == -1);
        if (!bad) r = x % y;
        break;
      case IOp::kMin:
        r = std::min(x, y);
        break;
      case IOp::kMax:
        r = std::max(x, y);
        break;
      case IOp::kEq:
        r = x == y;
        break;
      case IOp::kNe:
        r = x != y;
        break;
      case IOp::kLt:
        r = x < y;
        break;
      case IOp::kLe:
        r = x <= y;
        break;
      case IOp::kGt:
        r = x > y;
        break;
      case IOp::kGe:
        r = x >= y;
        break;
      case IOp::kAnd:
        r = (x != 0) && (y != 0);
        break;
      case IOp::kOr:
        r = (x != 0) || (y != 0);
        break;
      default:
        break;
    }
    if (bad) {
      diags_.emit(DiagKind::kConstantOverflow, span,
                  std::string(source_.text().substr(span.begin, span.end - span.begin)));
      return error_expr(span);
    }
    return make_const(r, type, span);
  }

  bool numeric(Type t) { return t == Type::kInt || t == Type::kDuration; }

  IExprPtr resolve(const ast::Expr& e, const Ctx& c) {
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

  std::string source_text(Span s) const {
    return std::string(source_.text().substr(s.begin, s.end - s.begin));
  }

  IExprPtr signal_ref(uint16_t id, Span span, const Ctx& c) {
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
  IExprPtr field_ref(const std::string& name, Span span, const Ctx& c, IOp op) {
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

  bool has_index(const Ctx& c) const {
    if (!c.device || !c.commands) return false;
    for (uint16_t ci : *c.commands) {
      if (c.device->profile.commands[ci].repeat > 1) return true;
    }
    return false;
  }

  IExprPtr resolve_name(const ast::Expr& e, const Ctx& c) {
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
  std::optional<std::vector<uint16_t>> resolve_member(const ast::Expr& e, const Ctx& c) {
    const ast::Expr& base = *e.kids[0];
    if (base.kind != ExprKind::kName) {
      diags_.emit(DiagKind::kExpectedToken, base.span, "a sensor name before `.`",
                  "`" + source_text(base.span) + "`");
      return std::nullopt;
    }
    const Sym* sym = lookup(base.name);
    if (!sym && c.constant &&
        std::any_of(file_.devices.begin(), file_.devices.end(),
                    [&](const ast::DeviceDecl& d) { return d.name.name == base.name; })) {
      diags_.emit(DiagKind::kNotConstant, e.span, c.what, "sensor `" + base.name + "`");
      return std::nullopt;
    }
    if (!sym) {
      diags_.emit(DiagKind::kUnknownName, base.span, base.name, "a sensor");
      return std::nullopt;
    }
    if (sym->kind != SymKind::kDevice) {
      diags_.emit(DiagKind::kTypeMismatch, base.span, "`" + base.name + "`", sym_phrase(sym->kind),
                  "a sensor");
      return std::nullopt;
    }
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

  uint16_t raw_signal(uint16_t dev, size_t field, Span span) {
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

  std::optional<std::vector<uint16_t>> resolve_list_signal(const ast::Expr& e, const Ctx& c) {
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

  std::optional<std::vector<int64_t>> const_list(const ast::Expr& e, const std::string& what) {
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

  IExprPtr resolve_call(const ast::Expr& e, const Ctx& c) {
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
  IExprPtr resolve_history(const ast::Expr& e, const Ctx& c, Positional& positional) {
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
      diags_.emit(DiagKind::kTypeMismatch, e.kids[required]->span,
                  "the default of `" + e.name + "`", type_phrase(d->type), type_phrase(r->type));
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

  // Σ (raw_i − white_i)·100 / (black_i − white_i) · w_i, as the vendor
  // computes it in floating point: each term is taken kLineScale times larger
  // and the sum divided once (truncating), so the result is within 1 of the
  // vendor's value (a per-term truncation was off by up to Σ|w_i|, enough to
  // judge an honest command near the threshold against the wrong branch).
  static constexpr int64_t kLineScale = 1000;
  IExprPtr resolve_line_position(const ast::Expr& e, const Ctx& c) {
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
      t = fold(IOp::kMul, Type::kInt, {t, make_const(100 * kLineScale, Type::kInt, e.span)},
               e.span);
      t = fold(IOp::kDiv, Type::kInt, {t, make_const((*b)[i] - (*w)[i], Type::kInt, e.span)},
               e.span);
      t = fold(IOp::kMul, Type::kInt, {t, make_const((*m)[i], Type::kInt, e.span)}, e.span);
      sum = sum ? fold(IOp::kAdd, Type::kInt, {sum, t}, e.span) : t;
    }
    if (!sum) return make_const(0, Type::kInt, e.span);
    return fold(IOp::kDiv, Type::kInt, {sum, make_const(kLineScale, Type::kInt, e.span)}, e.span);
  }

  IExprPtr resolve_binary(const ast::Expr& e, const Ctx& c) {
    IExprPtr a = resolve(*e.kids[0], c);
    IExprPtr b = resolve(*e.kids[1], c);
    if (a->type == Type::kError || b->type == Type::kError) return error_expr(e.span);
    const std::string& op = e.name;
    auto mismatch = [&](const char* expected) {
      diags_.emit(DiagKind::kOperandMismatch, e.span, op, type_phrase(a->type),
                  type_phrase(b->type), expected);
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

  IExprPtr resolve_in(const ast::Expr& e, const Ctx& c) {
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

  // --- devices -------------------------------------------------------------
  void declare_device(const ast::DeviceDecl& d) {
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

  bool build_regmap(const ast::DeviceDecl& d, devices::ProfileSpec& p) {
    p.name = "regmap";
    p.kind = core::Profile::kRegisterMap;
    p.role = 0;
    p.auto_increment =
        d.auto_increment ? core::AutoIncrement::kAlways : core::AutoIncrement::kNever;
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
      devices::FieldSpec f;
      f.geometry = core::FieldRecord{};
      f.name = "value";
      f.geometry.offset = 0;
      f.geometry.nbytes = type->nbytes;
      f.geometry.width = static_cast<uint8_t>(type->nbytes * 8);
      f.geometry.flags = static_cast<uint8_t>((type->big_endian ? core::kFieldBigEndian : 0) |
                                              (type->is_signed ? core::kFieldSigned : 0));
      const int bits = type->nbytes * 8;
      f.min = type->is_signed ? -(int64_t{1} << (bits - 1)) : 0;
      f.max = type->is_signed ? (int64_t{1} << (bits - 1)) - 1 : (int64_t{1} << bits) - 1;
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
          diags_.emit(DiagKind::kBadRegister, v.type.span,
                      "unknown value type `" + v.type.name + "`",
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
        devices::FieldSpec f;
        f.geometry = core::FieldRecord{};
        f.geometry = core::FieldRecord{};
        f.name = v.name.name;
        f.geometry.offset = static_cast<uint8_t>(*off);
        f.geometry.nbytes = type->nbytes;
        f.geometry.width = static_cast<uint8_t>(type->nbytes * 8);
        f.geometry.flags = static_cast<uint8_t>((type->big_endian ? core::kFieldBigEndian : 0) |
                                                (type->is_signed ? core::kFieldSigned : 0));
        const int bits = type->nbytes * 8;
        f.min = type->is_signed ? -(int64_t{1} << (bits - 1)) : 0;
        f.max = type->is_signed ? (int64_t{1} << (bits - 1)) - 1 : (int64_t{1} << bits) - 1;
        if (v.range) range_bounds(*v.range, f.min, f.max);
        p.sample_fields.push_back(f);
      }
    }
    if (p.role == 0) p.role = core::kRoleActuator;
    return ok;
  }

  void range_bounds(const ast::Expr& r, int64_t& lo, int64_t& hi) {
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

  void resolve_safe_state(const ast::DeviceDecl& d) {
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
      auto cv = command_value(*call, static_cast<uint16_t>(sym->index), CallMode::kTemplate,
                              nullptr, "the safe state of `" + dev.name + "`");
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

  // --- commands ------------------------------------------------------------
  enum class CallMode { kExpect, kTemplate, kComputed };

  void unknown_field(const std::string& name, Span span, const Device& dev, uint16_t cmd) {
    std::vector<std::string> names;
    for (const auto& f : dev.profile.commands[cmd].fields) names.push_back(f.name);
    diags_.emit(DiagKind::kUnknownField, span, dev.profile.commands[cmd].name, name,
                join_names(names));
  }

  std::optional<uint16_t> find_command(const Device& dev, const std::string& name) const {
    for (size_t i = 0; i < dev.profile.commands.size(); ++i) {
      if (dev.profile.commands[i].name == name) return static_cast<uint16_t>(i);
    }
    return std::nullopt;
  }
  std::vector<std::string> command_names(const Device& dev) const {
    std::vector<std::string> names;
    for (const auto& c : dev.profile.commands) {
      if (c.command_class == core::CommandClass::kActuate) names.push_back(c.name);
    }
    return names;
  }

  // Checks a value against a field's range (values in the field's unit).
  bool in_field_range(const IExprPtr& v, const devices::FieldSpec& f, const std::string& what) {
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
  bool value_fits(const IExprPtr& v, const devices::FieldSpec& f) {
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
  std::optional<CommandValue> command_value(const ast::Expr& call, uint16_t dev_id, CallMode mode,
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
  std::optional<std::vector<uint16_t>> selector_commands(const ast::Selector& s, uint16_t dev_id) {
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
  std::vector<uint16_t> all_actuation(const Device& dev) const {
    std::vector<uint16_t> cmds;
    for (size_t i = 0; i < dev.profile.commands.size(); ++i) {
      if (dev.profile.commands[i].command_class == core::CommandClass::kActuate) {
        cmds.push_back(static_cast<uint16_t>(i));
      }
    }
    return cmds;
  }

  // Looks up a device by name for a rule; reports and returns nullopt if bad.
  std::optional<uint16_t> rule_device(const ast::Ident& id, const std::string& what,
                                      bool need_actuator) {
    const Sym* sym = lookup(id.name);
    if (!sym) {
      diags_.emit(DiagKind::kUnknownName, id.span, id.name, "a device");
      return std::nullopt;
    }
    if (sym->kind != SymKind::kDevice) {
      diags_.emit(DiagKind::kTypeMismatch, id.span, "`" + id.name + "`", sym_phrase(sym->kind),
                  "a device");
      return std::nullopt;
    }
    if (!dev_ok_[sym->index]) return std::nullopt;
    const Device& dev = out_.devices[sym->index];
    if (need_actuator && !(dev.role & core::kRoleActuator)) {
      diags_.emit(DiagKind::kNotAnActuator, id.span, id.name, what);
      return std::nullopt;
    }
    return static_cast<uint16_t>(sym->index);
  }
  std::optional<uint16_t> rule_task(const ast::Ident& id) {
    const Sym* sym = lookup(id.name);
    if (!sym) {
      diags_.emit(DiagKind::kUnknownName, id.span, id.name, "a task");
      return std::nullopt;
    }
    if (sym->kind != SymKind::kTask) {
      diags_.emit(DiagKind::kTypeMismatch, id.span, "`" + id.name + "`", sym_phrase(sym->kind),
                  "a task");
      return std::nullopt;
    }
    return static_cast<uint16_t>(sym->index);
  }

  // --- tasks, signals, access ----------------------------------------------
  void declare_task(const ast::TaskDecl& d, uint32_t overhead_ns) {
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
        if (auto v = int_in(*p.value, "`priority`", 0, 65535))
          t.priority = static_cast<uint16_t>(*v);
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

  void declare_signal(const ast::SignalDecl& d) {
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

  void apply_allow(const ast::AllowDecl& a) {
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
        const bool readable = (device.role & core::kRoleSensor) || device.profile.read_back ||
                              std::any_of(device.profile.commands.begin(),
                                          device.profile.commands.end(), [](const auto& c) {
                                            return c.command_class == core::CommandClass::kQuery;
                                          });
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

  // --- responses -----------------------------------------------------------
  std::optional<Response> response(const ast::Response& r, uint16_t dev_id,
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
          auto it = std::find_if(std::begin(kErrnos), std::end(kErrnos),
                                 [&](const Errno& e) { return r.errno_name.name == e.name; });
          if (it == std::end(kErrnos)) {
            diags_.emit(DiagKind::kUnknownErrno, r.errno_name.span, r.errno_name.name);
            return std::nullopt;
          }
          out.reply_errno = it->value;
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
        out.kind =
            cv->constant() ? ResponseKind::kFailsafeTemplate : ResponseKind::kFailsafeComputed;
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
        out.kind =
            cv.constant() ? ResponseKind::kFailsafeTemplate : ResponseKind::kFailsafeComputed;
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
  void clear_unnamed_overrides(CommandValue& cv, const Device& dev,
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

  // --- rules -----------------------------------------------------------------
  void check_limit(const ast::LimitDecl& l) {
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
    r.text = collapse(source_text(l.span));
    r.span = l.span;
    out_.rates.push_back(std::move(r));
  }

  // The channel of a selection `dev.led(5)`: a repeated register group's
  // channel, within its repeat count.
  std::optional<int64_t> selected_channel(const ast::Expr& index, Span target,
                                          const std::vector<uint16_t>& cmds, const Device& device) {
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

  static std::string collapse(const std::string& s) {
    std::string out;
    bool space = false;
    bool comment = false;
    for (char c : s) {
      if (comment) {
        if (c == '\n')
          comment = false;
        else
          continue;
      }
      if (c == '#') {
        comment = true;
        continue;
      }
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
        space = true;
        continue;
      }
      if (space && !out.empty()) out += ' ';
      space = false;
      out += c;
    }
    return out;
  }

  IExprPtr condition(const ast::Expr& e, const Ctx& ctx) {
    IExprPtr v = resolve(e, ctx);
    if (v->type == Type::kError) return nullptr;
    if (v->type != Type::kBool) {
      diags_.emit(DiagKind::kTypeMismatch, e.span, "the condition", type_phrase(v->type),
                  "a boolean (a comparison, `in`, `and`, `or`, `not`)");
      return nullptr;
    }
    return v;
  }

  void check_invariant(const ast::InvariantDecl& d) {
    Invariant inv;
    inv.name = d.name.name;
    inv.span = d.name.span;
    inv.text = collapse(source_text(d.span));
    const bool declared =
        declare(inv.name, SymKind::kInvariant, out_.invariants.size(), d.name.span);
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
        auto cv = command_value(*call, *dev, CallMode::kExpect, nullptr,
                                "an expected command of " + rule);
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
    }
    auto resp =
        response(d.response, *dev, cmds, true, d.form != ast::InvariantForm::kRequire, rule);
    if (!resp) return;
    inv.response = std::move(*resp);
    if (!ok || !declared) return;
    warn_if_never_starts(inv, d.span);
    out_.invariants.push_back(std::move(inv));
  }

  // True if `e` reads the command history where no default guards it: before
  // the first command of its kind reached the device, it faults.
  static bool reads_unguarded_history(const IExpr* e) {
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
  void warn_if_never_starts(const Invariant& inv, Span span) {
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

  // A sensor without `max_age` gets the documented default: twice its sample
  // period, or the longest period of a task that may read it when that is
  // longer (a controller reads at the start of its job and commands within
  // the period, judged against that reading). Never unbounded: a sensor that
  // stops answering makes its signals unavailable.
  void default_max_ages() {
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

  void final_checks() {
    for (size_t i = 0; i < out_.devices.size(); ++i) {
      const Device& d = out_.devices[i];
      if ((d.role & core::kRoleActuator) && !d.commanded && dev_ok_[i] &&
          !all_actuation(d).empty()) {
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
  static bool compatible(const CommandValue& a, const CommandValue& b) {
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

  const ast::File& file_;
  const SourceBuffer& source_;
  DiagnosticEmitter& diags_;
  const ProfileLookup& profiles_;
  bool quiet_comparisons_ = false;  // W0704 is decided by the enclosing `in`
  CheckedPolicy out_;
  std::map<std::string, Sym> names_;
  std::vector<Const> consts_;
  std::vector<std::vector<uint16_t>> list_signals_;
  std::vector<Span> list_spans_;
  std::vector<bool> dev_ok_;
  std::set<size_t> bad_signals_;
  std::vector<std::pair<std::string, Span>> aliases_;  // `signal level = tank.level`
  std::set<std::string> used_aliases_;
  bool overhead_seen_ = false;
};

}  // namespace

std::string_view type_phrase(Type type) {
  switch (type) {
    case Type::kInt:
      return "a plain number";
    case Type::kDuration:
      return "a duration";
    case Type::kBool:
      return "a boolean";
    case Type::kError:
      return "invalid";
  }
  return "invalid";
}

bool CommandValue::constant() const {
  for (const auto& f : fields) {
    if (f.value && !f.value->is_const()) return false;
  }
  return true;
}

std::string to_string(const IExpr& e) {
  static const char* kNames[] = {
      "const", "signal", "field", "last", "since_last", "index", "jobcount", "neg",    "not",
      "abs",   "add",    "sub",   "mul",  "div",        "mod",   "min",      "max",    "eq",
      "ne",    "lt",     "le",    "gt",   "ge",         "and",   "or",       "last_or"};
  std::string out = kNames[static_cast<int>(e.op)];
  if (e.op == IOp::kConst) return std::to_string(e.value);
  if (e.op == IOp::kSignal || e.op == IOp::kField || e.op == IOp::kLastField) {
    out += std::to_string(e.slot);
  }
  if (!e.kids.empty()) {
    out += "(";
    for (size_t i = 0; i < e.kids.size(); ++i) {
      if (i) out += ",";
      out += to_string(*e.kids[i]);
    }
    out += ")";
  }
  return out;
}

CheckedPolicy check(const ast::File& file, const SourceBuffer& source, DiagnosticEmitter& diags,
                    const ProfileLookup& profiles) {
  return Sema(file, source, diags, profiles).run();
}

}  // namespace contego::policy
