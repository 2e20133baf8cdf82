#include "policy/check/context.h"

namespace contego::policy::check_internal {

IExprPtr Sema::make_const(int64_t v, Type t, Span span) {
  auto e = std::make_shared<IExpr>();
  e->op = IOp::kConst;
  e->type = t;
  e->value = v;
  e->lo = e->hi = v;
  e->span = span;
  return e;
}

IExprPtr Sema::error_expr(Span span) {
  auto e = std::make_shared<IExpr>();
  e->type = Type::kError;
  e->span = span;
  return e;
}

void Sema::declare_const(const ast::ConstDecl& c) {
  Ctx ctx;
  ctx.what = "constant `" + c.name.name + "`";
  ctx.constant = true;
  ctx.signals = false;
  IExprPtr v = resolve(*c.value, ctx);
  if (!declare(c.name.name, SymKind::kConst, consts_.size(), c.name.span)) return;
  consts_.push_back(Const{c.name.name, c.name.span, v});
}

// Evaluates a constant expression of the given type; reports problems.
std::optional<int64_t> Sema::const_value(const ast::Expr& e, Type want, const std::string& what) {
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

uint32_t Sema::duration_us(const ast::Expr& e, const std::string& what) {
  auto v = const_value(e, Type::kDuration, what);
  if (!v) return 0;
  if (*v < 0 || *v > std::numeric_limits<uint32_t>::max()) {
    diags_.emit(DiagKind::kValueOutOfRange, e.span, what, std::to_string(*v) + "us", "a duration",
                "0us", std::to_string(std::numeric_limits<uint32_t>::max()) + "us");
    return 0;
  }
  return static_cast<uint32_t>(*v);
}

uint32_t Sema::duration_ns(const ast::Expr& e, const std::string& what) {
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

std::optional<int64_t> Sema::int_in(const ast::Expr& e, const std::string& what, int64_t lo,
                                    int64_t hi) {
  auto v = const_value(e, Type::kInt, what);
  if (!v) return std::nullopt;
  if (*v < lo || *v > hi) {
    diags_.emit(DiagKind::kValueOutOfRange, e.span, what, *v, what, lo, hi);
    return std::nullopt;
  }
  return v;
}

IExprPtr Sema::fold(IOp op, Type type, std::vector<IExprPtr> kids, Span span) {
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
    if (op == IOp::kAnd && ((a->is_const() && a->value == 0) || (b->is_const() && b->value == 0))) {
      e->lo = e->hi = 0;
    }
    if (op == IOp::kOr && ((a->is_const() && a->value != 0) || (b->is_const() && b->value != 0))) {
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

bool Sema::numeric(Type t) { return t == Type::kInt || t == Type::kDuration; }

}  // namespace contego::policy::check_internal
