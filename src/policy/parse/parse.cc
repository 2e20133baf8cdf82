#include "policy/parse/parse.h"

#include <algorithm>
#include <initializer_list>
#include <string_view>

namespace contego::policy {
namespace {

using ast::Expr;
using ast::ExprKind;
using ast::ExprPtr;

constexpr std::string_view kStatementKeywords[] = {"const",    "device", "signal", "task",
                                                   "overhead", "allow",  "limit",  "invariant"};

bool is_statement_keyword(const Token& t) {
  if (t.kind != Tok::kIdent) return false;
  for (auto k : kStatementKeywords) {
    if (t.text == k) return true;
  }
  return false;
}

class Parser {
 public:
  Parser(const std::vector<Token>& tokens, DiagnosticEmitter& diags)
      : tokens_(tokens), diags_(diags) {}

  ast::File run() {
    skip_error_tokens();
    while (peek().kind != Tok::kEnd) {
      failed_ = false;
      stmt_start_ = consumed_end_;
      parse_statement();
      if (failed_) recover_statement();
      while (peek().kind == Tok::kSemi) advance();
    }
    return std::move(file_);
  }

 private:
  // --- token access --------------------------------------------------------
  void skip_error_tokens() {
    while (pos_ < tokens_.size() && tokens_[pos_].kind == Tok::kError) ++pos_;
  }
  const Token& peek(size_t ahead = 0) const {
    size_t i = pos_;
    for (size_t n = 0;; ++i) {
      if (i >= tokens_.size() - 1) return tokens_.back();
      if (tokens_[i].kind == Tok::kError) continue;
      if (n++ == ahead) return tokens_[i];
    }
  }
  const Token& advance() {
    const Token& t = peek();
    prev_end_ = t.span.end;
    if (pos_ < tokens_.size() - 1) {
      while (tokens_[pos_].kind == Tok::kError) ++pos_;
      consumed_end_ = pos_ + 1;
      ++pos_;
    }
    skip_error_tokens();
    return t;
  }
  bool at(Tok kind) const { return peek().kind == kind; }
  bool at_word(std::string_view word) const {
    return peek().kind == Tok::kIdent && peek().text == word;
  }
  bool accept(Tok kind) {
    if (!at(kind)) return false;
    advance();
    return true;
  }
  bool accept_word(std::string_view word) {
    if (!at_word(word)) return false;
    advance();
    return true;
  }

  // True if a lexical error (already reported) lies inside the current
  // statement: then syntax errors there are its consequences, not news.
  bool lexical_error_in_statement() const {
    for (size_t i = stmt_start_; i <= pos_ && i < tokens_.size(); ++i) {
      if (tokens_[i].kind == Tok::kError) return true;
    }
    return false;
  }
  // Reports "expected X, found Y" once per statement.
  void fail(std::string_view expected) {
    if (failed_) return;
    failed_ = true;
    if (lexical_error_in_statement()) return;
    diags_.emit(DiagKind::kExpectedToken, peek().span, expected, describe(peek()));
  }
  bool expect(Tok kind, std::string_view what = {}) {
    if (accept(kind)) return true;
    fail(what.empty() ? tok_spelling(kind) : what);
    return false;
  }
  bool expect_word(std::string_view word) {
    if (accept_word(word)) return true;
    fail("`" + std::string(word) + "`");
    return false;
  }
  bool ident(ast::Ident& out, std::string_view what) {
    if (!at(Tok::kIdent)) {
      fail(what);
      return false;
    }
    const Token& t = advance();
    out = {t.text, t.span};
    return true;
  }

  // Skips to the next statement keyword that starts a line.
  void recover_statement() {
    int depth = 0;
    while (!at(Tok::kEnd)) {
      const Token& t = peek();
      if (t.line_start && depth <= 0 && is_statement_keyword(t)) return;
      if (t.kind == Tok::kLBrace) ++depth;
      if (t.kind == Tok::kRBrace) --depth;
      advance();
    }
  }
  // Inside a `{ }` block: skips to the next item (a new line or after `;`)
  // or to the block's `}`. Always consumes at least one token if the item
  // consumed none, so the block loop makes progress.
  void recover_item(size_t item_start) {
    int depth = 0;
    if (pos_ == item_start && !at(Tok::kRBrace) && !at(Tok::kEnd)) advance();
    while (!at(Tok::kEnd)) {
      const Token& t = peek();
      if (depth <= 0 && t.kind == Tok::kRBrace) return;
      if (depth <= 0 && t.line_start) return;
      if (depth <= 0 && t.kind == Tok::kSemi) {
        advance();
        return;
      }
      if (t.kind == Tok::kLBrace || t.kind == Tok::kLParen || t.kind == Tok::kLBracket) ++depth;
      if (t.kind == Tok::kRParen || t.kind == Tok::kRBracket || t.kind == Tok::kRBrace) --depth;
      if (t.line_start && is_statement_keyword(t)) return;
      advance();
    }
  }

  // Parses `{ item* }`, calling item() for each; recovers per item. Returns
  // false if the block could not be closed (then the statement is skipped).
  template <typename F>
  bool block(F item, bool& incomplete) {
    if (!expect(Tok::kLBrace)) return false;
    while (!at(Tok::kRBrace)) {
      if (at(Tok::kEnd) || (peek().line_start && is_statement_keyword(peek()))) {
        fail("`}`");
        return false;
      }
      if (accept(Tok::kSemi)) continue;
      const size_t item_start = pos_;
      item();
      if (failed_) {
        // Reported; skip to the next item and keep checking the block.
        recover_item(item_start);
        incomplete = true;
        failed_ = false;
      }
    }
    advance();
    return true;
  }

  // --- statements ----------------------------------------------------------
  void parse_statement() {
    const Token& t = peek();
    if (t.kind == Tok::kIdent) {
      if (t.text == "const") return parse_named_value("a constant name", file_.consts);
      if (t.text == "device") return parse_device();
      if (t.text == "signal") return parse_named_value("a signal name", file_.signals);
      if (t.text == "task") return parse_task();
      if (t.text == "overhead") return parse_overhead();
      if (t.text == "allow") return parse_allow();
      if (t.text == "limit") return parse_limit();
      if (t.text == "invariant") return parse_invariant();
    }
    failed_ = true;
    if (!lexical_error_in_statement())
      diags_.emit(DiagKind::kExpectedStatement, t.span, describe(t));
  }

  // `const NAME = expr` and `signal NAME = expr`.
  template <typename Decl>
  void parse_named_value(const char* what, std::vector<Decl>& out) {
    advance();
    Decl d;
    if (!ident(d.name, what)) return;
    if (!expect(Tok::kAssign)) return;
    d.value = expr();
    if (failed_) return;
    out.push_back(std::move(d));
  }

  void parse_overhead() {
    const uint32_t begin = advance().span.begin;
    ast::OverheadDecl d;
    d.value = expr();
    d.span = {begin, prev_end_};
    if (failed_) return;
    file_.overheads.push_back(std::move(d));
  }

  void parse_device() {
    const uint32_t begin = advance().span.begin;
    ast::DeviceDecl d;
    if (!ident(d.name, "a device name")) return;
    if (!expect(Tok::kColon)) return;
    if (!ident(d.profile,
               "a device profile such as `gopigo2`, `pca9685`, `line_follower` or "
               "`regmap`")) {
      return;
    }
    if (!expect_word("at")) return;
    // i2c-N: lexed as the name `i2c`, `-`, a number.
    const uint32_t bus_begin = peek().span.begin;
    if (!at_word("i2c") || peek(1).kind != Tok::kMinus || peek(2).kind != Tok::kInt) {
      fail("a bus such as `i2c-1`");
      return;
    }
    advance();
    advance();
    d.bus = primary();
    d.bus_span = {bus_begin, prev_end_};
    d.address = additive();
    if (failed_) return;
    while (true) {
      if (accept_word("sample")) {
        d.sample_period = additive();
      } else if (accept_word("max_age")) {
        d.max_age = additive();
      } else {
        break;
      }
      if (failed_) return;
    }
    if (at(Tok::kLBrace)) {
      if (!block([&] { device_item(d); }, d.incomplete)) return;
    }
    d.span = {begin, prev_end_};
    file_.devices.push_back(std::move(d));
  }

  void device_item(ast::DeviceDecl& d) {
    const Token& t = peek();
    if (t.kind != Tok::kIdent) {
      fail("a device setting");
      return;
    }
    const uint32_t begin = t.span.begin;
    if (accept_word("safe")) {
      do {
        ExprPtr call = postfix();
        if (failed_) return;
        if (call->kind != ExprKind::kCall) {
          diags_.emit(DiagKind::kExpectedToken, call->span, "a command such as `stop()`",
                      "`" + call->name + "`");
          failed_ = true;
          return;
        }
        d.safe.push_back(std::move(call));
      } while (accept(Tok::kComma));
      d.safe_span = {begin, prev_end_};
    } else if (accept_word("latch")) {
      // Items of more than one part are kept whole or not at all: the checker
      // may rely on every part of a clause it is given.
      if (!expect_word("after")) return;
      ExprPtr count = additive();
      if (failed_) return;
      const bool unrepaired = accept_word("unrepaired");
      if (!expect_word("violations") || !expect_word("within")) return;
      ExprPtr window = additive();
      if (failed_) return;
      d.latch_unrepaired = unrepaired;
      d.latch_count = std::move(count);
      d.latch_window = std::move(window);
      d.latch_span = {begin, prev_end_};
    } else if (accept_word("auto_increment")) {
      d.auto_increment = true;
    } else if (at_word("register") || at_word("query")) {
      ast::RegisterDecl r;
      if (accept_word("query")) r.query = true;
      if (!expect_word("register")) return;
      r.first = additive();
      if (accept(Tok::kDotDot)) r.last = additive();
      if (failed_ || !ident(r.name, "a register name") || !expect(Tok::kColon) ||
          !ident(r.type, "a register type (`u8`, `s8`, `u16le`, `u16be`, `s16le`, `s16be`)")) {
        return;
      }
      if (accept_word("range")) r.range = range_expr();
      r.span = {begin, prev_end_};
      if (!failed_) d.registers.push_back(std::move(r));
    } else if (accept_word("forbid")) {
      ExprPtr first = additive();
      ExprPtr last;
      if (accept(Tok::kDotDot)) last = additive();
      if (failed_) return;
      d.forbid.emplace_back(std::move(first), std::move(last));
      d.forbid_spans.push_back({begin, prev_end_});
    } else if (accept_word("read")) {
      ExprPtr request = primary();
      if (failed_ || !expect_word("length")) return;
      ExprPtr length = additive();
      if (failed_) return;
      d.sample_request = std::move(request);
      d.sample_length = std::move(length);
      d.read_span = {begin, prev_end_};
    } else if (accept_word("value")) {
      ast::ValueDecl v;
      if (!ident(v.name, "a value name") || !expect_word("at")) return;
      v.offset = additive();
      if (failed_ || !expect(Tok::kColon) ||
          !ident(v.type, "a value type (`u8`, `s8`, `u16le`, `u16be`, `s16le`, `s16be`)")) {
        return;
      }
      if (accept_word("range")) v.range = range_expr();
      v.span = {begin, prev_end_};
      if (!failed_) d.values.push_back(std::move(v));
    } else {
      diags_.emit(DiagKind::kUnknownDeviceSetting, t.span, t.text,
                  "`safe`, `latch`, `auto_increment`, `register`, `query register`, `forbid`, "
                  "`read` or `value`");
      failed_ = true;
    }
  }

  void parse_task() {
    const uint32_t begin = advance().span.begin;
    ast::TaskDecl d;
    if (!ident(d.name, "a task name")) return;
    if (!block([&] { task_item(d); }, d.incomplete)) return;
    d.span = {begin, prev_end_};
    file_.tasks.push_back(std::move(d));
  }

  void task_item(ast::TaskDecl& d) {
    ast::TaskProperty p;
    if (!ident(p.key, "a task property")) return;
    static constexpr std::string_view kKeys[] = {"period",   "phase",      "deadline", "wcet",
                                                 "priority", "actuations", "overhead", "sessions"};
    // Who may run the task (the monitor checks it; not in the image): a
    // string, or for `user` and `group` also a numeric id.
    const std::string& k = p.key.name;
    const bool id_key = k == "user" || k == "group";
    if (k == "ignore_errno") {  // an errno name, as after `reject`
      if (!at(Tok::kIdent)) return fail("an errno name such as `EIO`");
      p.text = advance().text;
    } else if (k == "exe" || k == "unit" || k == "cgroup" || id_key) {
      if (id_key && at(Tok::kInt)) {
        p.text = std::to_string(advance().value);
      } else if (!at(Tok::kString)) {
        fail(k == "exe"      ? "a string such as `\"/usr/bin/python3\"`"
             : k == "unit"   ? "a string such as `\"gripper.service\"`"
             : k == "cgroup" ? "a string such as `\"/system.slice/gripper.service\"`"
                             : "a name such as `\"robot\"` or a numeric id");
        return;
      } else {
        p.text = advance().text;
      }
    } else {
      bool known = false;
      for (auto key : kKeys) known = known || p.key.name == key;
      if (!known) {
        diags_.emit(DiagKind::kUnknownTaskProperty, p.key.span, p.key.name);
        failed_ = true;
        return;
      }
      p.value = expr();
      if (failed_) return;
    }
    d.properties.push_back(std::move(p));
  }

  void parse_allow() {
    const uint32_t begin = advance().span.begin;
    ast::AllowDecl d;
    if (!ident(d.task, "a task name")) return;
    if (accept_word("reads")) {
      d.reads = true;
    } else if (!expect(Tok::kArrow, "`->` or `reads`")) {
      return;
    }
    do {
      ast::Ident dev;
      if (!ident(dev, "a device name")) return;
      d.devices.push_back(dev);
    } while (accept(Tok::kComma));
    d.span = {begin, prev_end_};
    file_.allows.push_back(std::move(d));
  }

  bool selector(ast::Selector& s) {
    const uint32_t begin = peek().span.begin;
    if (!ident(s.device, "a device name")) return false;
    if (accept(Tok::kDot)) {
      if (accept(Tok::kLBrace)) {
        do {
          ast::Ident c;
          if (!ident(c, "a command name")) return false;
          s.commands.push_back(c);
        } while (accept(Tok::kComma));
        if (!expect(Tok::kRBrace)) return false;
      } else {
        ast::Ident c;
        if (!ident(c, "a command name or `{`")) return false;
        s.commands.push_back(c);
        if (accept(Tok::kLParen)) {
          s.index = expr();
          if (failed_ || !expect(Tok::kRParen)) return false;
        }
      }
    }
    s.span = {begin, prev_end_};
    return true;
  }

  void parse_limit() {
    const uint32_t begin = advance().span.begin;
    ast::LimitDecl d;
    if (!ident(d.task, "a task name") || !expect(Tok::kArrow) || !selector(d.target)) return;
    d.count = additive();
    if (failed_ || !expect_word("per") || !expect_word("job")) return;
    if (!expect_word("else") || !response(d.response)) return;
    d.span = {begin, prev_end_};
    file_.limits.push_back(std::move(d));
  }

  void parse_invariant() {
    const uint32_t begin = advance().span.begin;
    ast::InvariantDecl d;
    if (!ident(d.name, "an invariant name")) return;
    d.head_span = {begin, prev_end_};
    if (!expect_word("on") || !selector(d.target) || !expect(Tok::kColon)) return;
    if (accept_word("when")) {
      d.when = expr();
      if (failed_) return;
      if (accept_word("expect")) {
        d.form = ast::InvariantForm::kExpect;
        do {
          ExprPtr call = postfix();
          if (failed_) return;
          if (call->kind != ExprKind::kCall) {
            diags_.emit(DiagKind::kExpectedToken, call->span,
                        "a command such as `set_left_speed(85)`", "`" + call->name + "`");
            failed_ = true;
            return;
          }
          d.expect.push_back(std::move(call));
        } while (accept(Tok::kComma));
      } else if (accept_word("require")) {
        d.form = ast::InvariantForm::kRequire;
        d.require = expr();
      } else {
        fail("`expect` or `require`");
        return;
      }
    } else if (accept_word("require")) {
      d.form = ast::InvariantForm::kRequire;
      d.require = expr();
    } else if (accept_word("sequence")) {
      d.form = ast::InvariantForm::kSequence;
      if (!ident(d.sequence_field, "a field name")) return;
      if (!at(Tok::kLBracket)) {
        fail("a list of values such as `[420, 577]`");
        return;
      }
      d.sequence_values = primary();
      if (!failed_ && accept_word("scope") && !ident(d.scope, "`session`, `task` or `device`")) {
        return;
      }
    } else {
      fail("`when`, `require` or `sequence`");
      return;
    }
    if (failed_ || !expect_word("else") || !response(d.response)) return;
    d.span = {begin, prev_end_};
    file_.invariants.push_back(std::move(d));
  }

  bool response(ast::Response& r) {
    const uint32_t begin = peek().span.begin;
    const Token& t = peek();
    if (accept_word("ignore")) {
      r.kind = ast::ResponseKind::kIgnore;
    } else if (accept_word("reject")) {
      r.kind = ast::ResponseKind::kReject;
      if (at(Tok::kIdent) && !peek().line_start && peek().text[0] == 'E') {
        ident(r.errno_name, "an errno name");
      }
    } else if (accept_word("failsafe")) {
      if (accept_word("expected")) {
        r.kind = ast::ResponseKind::kFailsafeExpected;
      } else if (at(Tok::kIdent) && peek(1).kind == Tok::kAssign) {
        r.kind = ast::ResponseKind::kFailsafeAssign;
        do {
          ast::Assign a;
          if (!ident(a.field, "a field name") || !expect(Tok::kAssign)) return false;
          a.value = expr();
          if (failed_) return false;
          r.assigns.push_back(std::move(a));
        } while (accept(Tok::kComma));
      } else if (at(Tok::kIdent) && peek(1).kind == Tok::kLParen) {
        r.kind = ast::ResponseKind::kFailsafeCommand;
        r.command = postfix();
        if (failed_) return false;
      } else {
        fail("`expected`, a command such as `stop()`, or `FIELD = VALUE`");
        return false;
      }
    } else if (t.kind == Tok::kIdent) {
      diags_.emit(DiagKind::kUnknownResponse, t.span, t.text);
      failed_ = true;
      return false;
    } else {
      fail("a response (`ignore`, `reject`, `failsafe ...`)");
      return false;
    }
    r.span = {begin, prev_end_};
    return true;
  }

  // --- expressions ---------------------------------------------------------
  struct DepthGuard {
    explicit DepthGuard(Parser& p) : p_(p) { ++p_.depth_; }
    ~DepthGuard() { --p_.depth_; }
    Parser& p_;
  };

  ExprPtr error_expr() {
    auto e = std::make_unique<Expr>();
    e->kind = ExprKind::kError;
    e->span = peek().span;
    return e;
  }
  bool too_deep() {
    if (depth_ <= kMaxNesting) return false;
    if (!failed_) {
      diags_.emit(DiagKind::kNestingTooDeep, peek().span, kMaxNesting);
      failed_ = true;
    }
    return true;
  }

  static ExprPtr make(ExprKind kind, Span span, std::string name = {}) {
    auto e = std::make_unique<Expr>();
    e->kind = kind;
    e->span = span;
    e->name = std::move(name);
    return e;
  }
  // Every child goes in through here, so the tree's height is known at each
  // node: operator chains (`1 + 1 + ...`) and postfix chains grow the tree
  // without recursing in the parser, but every later pass recurses over it.
  void adopt(Expr& parent, ExprPtr kid) {
    parent.height = std::max(parent.height, kid->height + 1);
    parent.kids.push_back(std::move(kid));
    if (parent.height > kMaxExprHeight && !failed_) {
      diags_.emit(DiagKind::kExpressionTooLong, parent.span, kMaxExprHeight);
      failed_ = true;
    }
  }

  // The prefix operator `op` (the current token) applied to what `operand` parses.
  ExprPtr prefix(std::string op, ExprPtr (Parser::*operand)()) {
    const uint32_t begin = advance().span.begin;
    ExprPtr inner = (this->*operand)();
    auto e = make(ExprKind::kUnary, {begin, inner->span.end}, std::move(op));
    adopt(*e, std::move(inner));
    return e;
  }
  ExprPtr binary(std::string op, ExprPtr l, ExprPtr r) {
    auto e = make(ExprKind::kBinary, {l->span.begin, r->span.end}, std::move(op));
    adopt(*e, std::move(l));
    adopt(*e, std::move(r));
    return e;
  }

  ExprPtr expr() { return or_expr(); }

  ExprPtr or_expr() {
    DepthGuard g(*this);
    if (too_deep()) return error_expr();
    ExprPtr l = and_expr();
    while (!failed_ && accept_word("or")) l = binary("or", std::move(l), and_expr());
    return l;
  }
  ExprPtr and_expr() {
    ExprPtr l = not_expr();
    while (!failed_ && accept_word("and")) l = binary("and", std::move(l), not_expr());
    return l;
  }
  ExprPtr not_expr() {
    DepthGuard g(*this);
    if (too_deep()) return error_expr();
    if (at_word("not")) return prefix("not", &Parser::not_expr);
    return comparison();
  }
  ExprPtr comparison() {
    ExprPtr l = additive();
    if (failed_) return l;
    static constexpr std::pair<Tok, std::string_view> kOps[] = {{Tok::kEq, "=="}, {Tok::kNe, "!="},
                                                                {Tok::kLt, "<"},  {Tok::kLe, "<="},
                                                                {Tok::kGt, ">"},  {Tok::kGe, ">="}};
    for (auto [tok, op] : kOps) {
      if (accept(tok)) return binary(std::string(op), std::move(l), additive());
    }
    bool negated = false;
    if (at_word("not") && peek(1).kind == Tok::kIdent && peek(1).text == "in") {
      advance();
      negated = true;
    }
    if (accept_word("in")) {
      ExprPtr r = range_expr();
      auto e = make(ExprKind::kIn, {l->span.begin, r->span.end}, "in");
      e->negated = negated;
      adopt(*e, std::move(l));
      adopt(*e, std::move(r));
      return e;
    }
    if (negated) fail("`in`");
    return l;
  }
  // `a..b` or `{a, b}` (for `in`, `range`).
  ExprPtr range_expr() {
    if (at(Tok::kLBrace)) return primary();
    ExprPtr lo = additive();
    if (failed_) return lo;
    if (!expect(Tok::kDotDot, "`..` (a range such as `0..100`) or a set such as `{1, 2}`")) {
      return lo;
    }
    ExprPtr hi = additive();
    auto e = make(ExprKind::kRange, {lo->span.begin, hi->span.end});
    adopt(*e, std::move(lo));
    adopt(*e, std::move(hi));
    return e;
  }
  using OpTable = std::initializer_list<std::pair<Tok, std::string_view>>;
  // One left-associative level: `next (op next)*` for the operators in `ops`.
  ExprPtr left_assoc(ExprPtr (Parser::*next)(), OpTable ops) {
    ExprPtr l = (this->*next)();
    while (!failed_) {
      auto hit =
          std::find_if(ops.begin(), ops.end(), [&](const auto& o) { return accept(o.first); });
      if (hit == ops.end()) break;
      l = binary(std::string(hit->second), std::move(l), (this->*next)());
    }
    return l;
  }
  ExprPtr additive() {
    return left_assoc(&Parser::multiplicative, {{Tok::kPlus, "+"}, {Tok::kMinus, "-"}});
  }
  ExprPtr multiplicative() {
    return left_assoc(&Parser::unary,
                      {{Tok::kStar, "*"}, {Tok::kSlash, "/"}, {Tok::kPercent, "%"}});
  }
  ExprPtr unary() {
    DepthGuard g(*this);
    if (too_deep()) return error_expr();
    if (at(Tok::kMinus)) return prefix("-", &Parser::unary);
    return postfix();
  }
  ExprPtr postfix() {
    ExprPtr e = primary();
    while (!failed_) {
      if (accept(Tok::kDot)) {
        ast::Ident member;
        if (!ident(member, "a name after `.`")) return e;
        auto m = make(ExprKind::kMember, {e->span.begin, member.span.end}, member.name);
        m->name_span = member.span;
        adopt(*m, std::move(e));
        e = std::move(m);
      } else if (at(Tok::kLBracket) && e->kind != ExprKind::kInt) {
        advance();
        ExprPtr idx = expr();
        if (failed_ || !expect(Tok::kRBracket)) return e;
        auto m = make(ExprKind::kIndex, {e->span.begin, prev_end_});
        adopt(*m, std::move(e));
        adopt(*m, std::move(idx));
        e = std::move(m);
      } else if (at(Tok::kLParen) && e->kind == ExprKind::kName) {
        advance();
        e->kind = ExprKind::kCall;
        e->name_span = e->span;
        if (!at(Tok::kRParen)) {
          do {
            if (at(Tok::kIdent) && peek(1).kind == Tok::kAssign) {
              const Token& n = advance();
              e->arg_names.push_back(n.text);
              e->arg_name_spans.push_back(n.span);
              advance();
            } else {
              e->arg_names.emplace_back();
              e->arg_name_spans.push_back(peek().span);
            }
            ExprPtr arg = at(Tok::kLBrace) ? primary() : expr();
            if (!failed_ && accept(Tok::kDotDot)) {  // a range argument: `speed=80..90`
              ExprPtr hi = additive();
              auto r = make(ExprKind::kRange, {arg->span.begin, hi->span.end});
              adopt(*r, std::move(arg));
              adopt(*r, std::move(hi));
              arg = std::move(r);
            }
            adopt(*e, std::move(arg));
            if (failed_) return e;
          } while (accept(Tok::kComma));
        }
        if (!expect(Tok::kRParen, "`,` or `)`")) return e;
        e->span.end = prev_end_;
      } else {
        break;
      }
    }
    return e;
  }
  ExprPtr primary() {
    DepthGuard g(*this);
    if (too_deep()) return error_expr();
    const Token& t = peek();
    switch (t.kind) {
      case Tok::kInt: {
        auto e = make(ExprKind::kInt, t.span, t.text);
        e->value = t.value;
        advance();
        return e;
      }
      case Tok::kDuration: {
        auto e = make(ExprKind::kDuration, t.span, t.text);
        e->value = t.value;
        advance();
        return e;
      }
      case Tok::kIdent: {
        if (t.line_start && is_statement_keyword(t)) {
          // The next statement: the expression was cut short.
          fail("a value (a number, a duration, a name, `(`, `[` or `{`)");
          return error_expr();
        }
        auto e = make(ExprKind::kName, t.span, t.text);
        advance();
        return e;
      }
      case Tok::kLParen: {
        advance();
        ExprPtr inner = expr();
        if (!failed_) expect(Tok::kRParen);
        return inner;
      }
      case Tok::kLBracket:
      case Tok::kLBrace: {
        const bool list = t.kind == Tok::kLBracket;
        const uint32_t begin = advance().span.begin;
        auto e = make(list ? ExprKind::kList : ExprKind::kSet, {begin, begin});
        const Tok close = list ? Tok::kRBracket : Tok::kRBrace;
        if (!at(close)) {
          do {
            if (e->kids.size() == kMaxElements) {
              diags_.emit(DiagKind::kTooManyElements, peek().span, list ? "a list" : "a set",
                          kMaxElements);
              failed_ = true;
            }
            if (failed_) return e;
            adopt(*e, expr());
            if (failed_) return e;
          } while (accept(Tok::kComma));
        }
        expect(close, list ? "`,` or `]`" : "`,` or `}`");
        e->span.end = prev_end_;
        return e;
      }
      default:
        fail("a value (a number, a duration, a name, `(`, `[` or `{`)");
        return error_expr();
    }
  }

  const std::vector<Token>& tokens_;
  DiagnosticEmitter& diags_;
  size_t pos_ = 0;
  size_t stmt_start_ = 0;
  size_t consumed_end_ = 0;  // index after the last consumed token
  uint32_t prev_end_ = 0;
  bool failed_ = false;
  int depth_ = 0;
  ast::File file_;
};

}  // namespace

ast::File parse(const std::vector<Token>& tokens, DiagnosticEmitter& diags) {
  return Parser(tokens, diags).run();
}

}  // namespace contego::policy
