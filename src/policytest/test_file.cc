#include "policytest/test_file.h"

#include <algorithm>
#include <cctype>
#include <fmt/format.h>
#include <limits>

namespace contego::policytest {
namespace {

enum class Tok { kWord, kString, kPunct, kArrow };

struct Token {
  Tok kind;
  std::string text;  // word / string contents / punctuation char
  Loc loc;
  size_t offset;  // byte offset of the token's start in its line
};

struct Line {
  std::vector<Token> tokens;
  std::string text;  // the source line (for excerpts)
  uint32_t number;
};

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Splits the file into lines of tokens; lexical errors are reported and the
// rest of that line is dropped.
std::vector<Line> lex(const std::string& text, std::vector<ParseError>& errors) {
  std::vector<Line> lines;
  size_t pos = 0;
  uint32_t number = 0;
  while (pos <= text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    Line line;
    line.number = ++number;
    line.text = text.substr(pos, end - pos);
    if (!line.text.empty() && line.text.back() == '\r') line.text.pop_back();
    const std::string& s = line.text;
    size_t i = 0;
    while (i < s.size()) {
      const char c = s[i];
      const Loc loc{number, static_cast<uint32_t>(i + 1)};
      if (c == ' ' || c == '\t') {
        ++i;
      } else if (c == '#') {
        break;
      } else if (c == '-' && i + 1 < s.size() && s[i + 1] == '>') {
        line.tokens.push_back({Tok::kArrow, "->", loc, i});
        i += 2;
      } else if (word_char(c) || ((c == '-' || c == '+') && i + 1 < s.size() &&
                                  std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
        size_t j = i + 1;
        while (j < s.size() &&
               (word_char(s[j]) || (s[j] == '-' && j + 1 < s.size() && word_char(s[j + 1])))) {
          ++j;
        }
        line.tokens.push_back({Tok::kWord, s.substr(i, j - i), loc, i});
        i = j;
      } else if (c == '"') {
        size_t j = s.find('"', i + 1);
        if (j == std::string::npos) {
          errors.push_back({loc, "unterminated string (expected a closing '\"' on this line)", ""});
          line.tokens.clear();
          break;
        }
        line.tokens.push_back({Tok::kString, s.substr(i + 1, j - i - 1), loc, i});
        i = j + 1;
      } else if (std::string_view("{}[](),=.").find(c) != std::string_view::npos) {
        line.tokens.push_back({Tok::kPunct, std::string(1, c), loc, i});
        ++i;
      } else {
        errors.push_back({loc, fmt::format("unexpected character '{}'", c), ""});
        line.tokens.clear();
        break;
      }
    }
    lines.push_back(std::move(line));
    if (end == text.size()) break;
    pos = end + 1;
  }
  return lines;
}

std::optional<int64_t> parse_int(const std::string& w) {
  if (w.empty()) return std::nullopt;
  size_t i = 0;
  bool neg = false;
  if (w[0] == '-' || w[0] == '+') {
    neg = w[0] == '-';
    i = 1;
  }
  int base = 10;
  if (w.size() > i + 2 && w[i] == '0' && (w[i + 1] == 'x' || w[i + 1] == 'X')) {
    base = 16;
    i += 2;
  }
  if (i >= w.size()) return std::nullopt;
  int64_t v = 0;
  for (; i < w.size(); ++i) {
    const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(w[i])));
    int d = -1;
    if (c >= '0' && c <= '9') d = c - '0';
    if (base == 16 && c >= 'a' && c <= 'f') d = c - 'a' + 10;
    if (d < 0) return std::nullopt;
    if (v > (std::numeric_limits<int64_t>::max() - d) / base) return std::nullopt;
    v = v * base + d;
  }
  return neg ? -v : v;
}

// A byte inside [..]: hex, with or without 0x ("6E", "0x6e", "1").
std::optional<uint8_t> parse_hex_byte(const std::string& w) {
  std::string s = w;
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) s = s.substr(2);
  if (s.empty() || s.size() > 2) return std::nullopt;
  auto v = parse_int("0x" + s);
  if (!v) return std::nullopt;
  return static_cast<uint8_t>(*v);
}

// "200ms", "250us", "1s", "2min" -> microseconds.
std::optional<uint64_t> parse_duration(const std::string& w) {
  size_t i = 0;
  while (i < w.size() && std::isdigit(static_cast<unsigned char>(w[i]))) ++i;
  if (i == 0) return std::nullopt;
  auto n = parse_int(w.substr(0, i));
  if (!n) return std::nullopt;
  const std::string unit = w.substr(i);
  uint64_t scale = 0;
  if (unit == "us") scale = 1;
  if (unit == "ms") scale = 1000;
  if (unit == "s") scale = 1000000;
  if (unit == "min") scale = 60000000;
  if (scale == 0 || static_cast<uint64_t>(*n) > std::numeric_limits<uint64_t>::max() / scale) {
    return std::nullopt;
  }
  return static_cast<uint64_t>(*n) * scale;
}

// Reads one line's tokens; the first error stops the line.
class LineParser {
 public:
  LineParser(const Line& line, std::vector<ParseError>& errors) : line_(line), errors_(errors) {}

  bool at_end() const { return i_ >= line_.tokens.size(); }
  const Token* peek() const { return at_end() ? nullptr : &line_.tokens[i_]; }
  bool peek_word(const char* w) const {
    return !at_end() && peek()->kind == Tok::kWord && peek()->text == w;
  }
  bool peek_punct(char c) const {
    return !at_end() && peek()->kind == Tok::kPunct && peek()->text[0] == c;
  }
  Loc here() const {
    if (!at_end()) return peek()->loc;
    return Loc{line_.number, static_cast<uint32_t>(line_.text.size() + 1)};
  }
  const std::string& text() const { return line_.text; }
  size_t offset() const { return at_end() ? line_.text.size() : peek()->offset; }

  bool fail(const std::string& message) {
    if (!failed_) errors_.push_back({here(), message, ""});
    failed_ = true;
    return false;
  }
  bool fail_at(Loc loc, const std::string& message) {
    if (!failed_) errors_.push_back({loc, message, ""});
    failed_ = true;
    return false;
  }
  bool failed() const { return failed_; }

  // What the current token is, for "expected X, found Y" messages.
  std::string found() const {
    if (at_end()) return "end of line";
    const Token& t = *peek();
    if (t.kind == Tok::kString) return fmt::format("string \"{}\"", t.text);
    return fmt::format("'{}'", t.text);
  }

  bool word(std::string* out, const char* what) {
    if (at_end() || peek()->kind != Tok::kWord) {
      return fail(fmt::format("expected {}, found {}", what, found()));
    }
    *out = line_.tokens[i_++].text;
    return true;
  }
  bool string(std::string* out, const char* what) {
    if (at_end() || peek()->kind != Tok::kString) {
      return fail(fmt::format("expected {}, found {}", what, found()));
    }
    *out = line_.tokens[i_++].text;
    return true;
  }
  bool punct(char c) {
    if (!peek_punct(c)) return fail(fmt::format("expected '{}', found {}", c, found()));
    ++i_;
    return true;
  }
  bool arrow() {
    if (at_end() || peek()->kind != Tok::kArrow) {
      return fail(fmt::format("expected '->' and the expected verdict, found {}", found()));
    }
    ++i_;
    return true;
  }
  bool integer(int64_t* out, const char* what) {
    if (at_end() || peek()->kind != Tok::kWord || !parse_int(peek()->text)) {
      return fail(fmt::format("expected {} (an integer), found {}", what, found()));
    }
    *out = *parse_int(line_.tokens[i_++].text);
    return true;
  }
  bool ranged(int64_t* out, const char* what, int64_t lo, int64_t hi) {
    const Loc loc = here();
    if (!integer(out, what)) return false;
    if (*out < lo || *out > hi) {
      errors_.push_back({loc, fmt::format("{} {} outside {}..{}", what, *out, lo, hi), ""});
      failed_ = true;
      return false;
    }
    return true;
  }
  bool duration(uint64_t* out) {
    if (at_end() || peek()->kind != Tok::kWord || !parse_duration(peek()->text)) {
      return fail(fmt::format("expected a duration such as 200ms, 250us or 1s, found {}", found()));
    }
    *out = *parse_duration(line_.tokens[i_++].text);
    return true;
  }
  bool bus(uint8_t* out) {
    if (at_end() || peek()->kind != Tok::kWord || peek()->text.rfind("i2c-", 0) != 0) {
      return fail(fmt::format("expected a bus such as i2c-1, found {}", found()));
    }
    auto n = parse_int(peek()->text.substr(4));
    if (!n || *n < 0 || *n > 255) return fail(fmt::format("bad bus number in {}", found()));
    *out = static_cast<uint8_t>(*n);
    ++i_;
    return true;
  }
  // [01 46 55 00 00]: hex bytes separated by spaces.
  bool bytes(std::vector<uint8_t>* out) {
    if (!punct('[')) return false;
    while (!peek_punct(']')) {
      if (at_end() || peek()->kind != Tok::kWord || !parse_hex_byte(peek()->text)) {
        return fail(fmt::format("expected a hex byte (00..ff) or ']', found {}", found()));
      }
      out->push_back(*parse_hex_byte(line_.tokens[i_++].text));
    }
    ++i_;
    return true;
  }
  // [1, 2, -3]
  bool int_list(std::vector<int64_t>* out) {
    if (!punct('[')) return false;
    while (!peek_punct(']')) {
      int64_t v = 0;
      if (!integer(&v, "a list element")) return false;
      out->push_back(v);
      if (!peek_punct(']') && !punct(',')) return false;
    }
    ++i_;
    return true;
  }
  // [device '.'] command '(' args ')'
  bool call(Call* out) {
    out->loc = here();
    std::string first;
    if (!word(&first, "a command")) return false;
    if (peek_punct('.')) {
      ++i_;
      out->device = first;
      if (!word(&out->command, "a command name after '.'")) return false;
    } else {
      out->command = first;
    }
    if (!punct('(')) return false;
    while (!peek_punct(')')) {
      Arg a;
      if (!at_end() && peek()->kind == Tok::kWord && i_ + 1 < line_.tokens.size() &&
          line_.tokens[i_ + 1].kind == Tok::kPunct && line_.tokens[i_ + 1].text == "=") {
        a.name = line_.tokens[i_].text;
        i_ += 2;
      }
      if (!integer(&a.value, "an argument value")) return false;
      out->args.push_back(std::move(a));
      if (!peek_punct(')') && !punct(',')) return false;
    }
    ++i_;
    return true;
  }

 private:
  const Line& line_;
  std::vector<ParseError>& errors_;
  size_t i_ = 0;
  bool failed_ = false;
};

bool parse_expect(LineParser& p, Expect* e) {
  e->loc = p.here();
  const size_t start = p.offset();
  const Loc verdict_loc = p.here();
  std::string verdict;
  if (!p.word(&verdict, "a verdict (allow, ignore, reject or failsafe)")) return false;
  if (verdict == "allow") {
    e->decision = core::Decision::kAllow;
  } else if (verdict == "ignore") {
    e->decision = core::Decision::kIgnore;
  } else if (verdict == "reject") {
    e->decision = core::Decision::kReject;
    if (!p.at_end() && !p.peek_word("reason") && !p.peek_word("rule")) {
      std::string w;
      const Loc loc = p.here();
      if (!p.word(&w, "an errno")) return false;
      auto n = parse_int(w);
      auto named = errno_from_name(w);
      if (!n && !named) {
        return p.fail_at(loc, fmt::format("unknown errno '{}' (expected a number or one of "
                                          "EPERM, EIO, EBADF, EAGAIN, EACCES, EBUSY, EINVAL)",
                                          w));
      }
      e->reply_errno = named ? *named : static_cast<int>(*n);
    }
  } else if (verdict == "failsafe") {
    e->decision = core::Decision::kFailsafe;
    while (!p.at_end() && !p.peek_word("reason") && !p.peek_word("rule")) {
      Call c;
      if (!p.call(&c)) return false;
      e->substitutes.push_back(std::move(c));
      if (p.peek_punct(',')) p.punct(',');
    }
  } else {
    return p.fail_at(
        verdict_loc,
        fmt::format("unknown verdict '{}' (expected allow, ignore, reject or failsafe)", verdict));
  }
  while (!p.at_end()) {
    std::string key;
    std::string value;
    if (p.peek_word("reason")) {
      p.word(&key, "");
      if (!p.word(&value, "a reason name such as rate-exceeded")) return false;
      e->reason = value;
    } else if (p.peek_word("rule")) {
      p.word(&key, "");
      if (!p.word(&value, "a rule name (an invariant or rate name, access, latch)")) return false;
      e->rule = value;
    } else {
      return p.fail(fmt::format("expected 'reason', 'rule' or end of line, found {}", p.found()));
    }
  }
  e->text = p.text().substr(start);
  while (!e->text.empty() && (e->text.back() == ' ' || e->text.back() == '\t')) e->text.pop_back();
  return true;
}

bool parse_smbus(LineParser& p, Step* s) {
  std::string form;
  if (!p.word(&form, "an SMBus transaction kind")) return false;
  int64_t cmd = 0;
  int64_t v = 0;
  if (form == "quick") {
    s->kind = core::TxKind::kQuick;
    return true;
  }
  if (form == "byte") {
    if (!p.ranged(&v, "the byte", 0, 255)) return false;
    s->bytes = {static_cast<uint8_t>(v)};
    return true;
  }
  if (!p.ranged(&cmd, "the command (register) byte", 0, 255)) return false;
  s->bytes = {static_cast<uint8_t>(cmd)};
  if (form == "byte_data") {
    if (!p.ranged(&v, "the data byte", 0, 255)) return false;
    s->bytes.push_back(static_cast<uint8_t>(v));
  } else if (form == "word_data" || form == "proc_call") {
    if (!p.ranged(&v, "the data word", 0, 65535)) return false;
    s->bytes.push_back(static_cast<uint8_t>(v & 0xFF));
    s->bytes.push_back(static_cast<uint8_t>(v >> 8));
  } else if (form == "block_data" || form == "i2c_block") {
    std::vector<uint8_t> data;
    if (!p.bytes(&data)) return false;
    if (data.empty() || data.size() > 32) return p.fail("an SMBus block holds 1..32 bytes");
    if (form == "block_data") s->bytes.push_back(static_cast<uint8_t>(data.size()));
    s->bytes.insert(s->bytes.end(), data.begin(), data.end());
  } else {
    return p.fail(
        fmt::format("unknown SMBus kind '{}' (expected quick, byte, byte_data, "
                    "word_data, proc_call, block_data or i2c_block)",
                    form));
  }
  return true;
}

// Parses a statement; returns nullopt on error (already reported).
std::optional<Action> parse_statement(LineParser& p) {
  const Loc loc = p.here();
  const size_t start = p.offset();
  std::string kw;
  if (!p.word(&kw, "a statement (task, job, at, after, sensor, send, write, read, smbus)")) {
    return std::nullopt;
  }
  auto done = [&](Action a) -> std::optional<Action> {
    if (!p.at_end()) {
      p.fail(fmt::format("expected end of line, found {}", p.found()));
      return std::nullopt;
    }
    return a;
  };
  if (kw == "task") {
    SetTask t{"", loc};
    if (!p.word(&t.task, "a task name")) return std::nullopt;
    return done(t);
  }
  if (kw == "job") {
    int64_t n = 0;
    if (!p.ranged(&n, "job number", 0, 0xFFFFFFFF)) return std::nullopt;
    return done(SetJob{static_cast<uint32_t>(n), loc});
  }
  if (kw == "at" || kw == "after") {
    SetTime t{0, kw == "after", loc};
    if (!p.duration(&t.us)) return std::nullopt;
    return done(t);
  }
  if (kw == "sensor") {
    SetSensor s;
    s.loc = loc;
    if (!p.word(&s.device, "a sensor device name")) return std::nullopt;
    if (p.peek_word("none")) {
      std::string w;
      p.word(&w, "");
      s.none = true;
      return done(s);
    }
    if (p.peek_word("sample")) {
      std::string w;
      p.word(&w, "");
      std::vector<uint8_t> b;
      if (!p.bytes(&b)) return std::nullopt;
      s.sample = std::move(b);
      return done(s);
    }
    do {
      std::string name;
      if (!p.word(&name, "a sample field name, 'sample' or 'none'")) return std::nullopt;
      if (!p.punct('=')) return std::nullopt;
      std::vector<int64_t> values;
      bool list = p.peek_punct('[');
      if (list) {
        if (!p.int_list(&values)) return std::nullopt;
      } else {
        int64_t v = 0;
        if (!p.integer(&v, "a sample value")) return std::nullopt;
        values.push_back(v);
      }
      s.fields.emplace_back(std::move(name), std::move(values));
      s.is_list.push_back(list);
    } while (!p.at_end());
    return s;
  }
  if (kw == "send" || kw == "write" || kw == "read" || kw == "smbus") {
    Step s;
    s.loc = loc;
    if (kw == "send") {
      Call c;
      if (!p.call(&c)) return std::nullopt;
      if (c.device.empty()) {
        p.fail_at(c.loc, "expected DEVICE.COMMAND(...) after 'send'");
        return std::nullopt;
      }
      s.call = std::move(c);
    } else {
      s.kind = kw == "read" ? core::TxKind::kRead : core::TxKind::kWrite;
      int64_t addr = 0;
      if (!p.bus(&s.bus) || !p.ranged(&addr, "address", 0, 0x3FF)) return std::nullopt;
      s.addr = static_cast<uint16_t>(addr);
      if (kw == "smbus") {
        if (!parse_smbus(p, &s)) return std::nullopt;
      } else if (kw == "write" || p.peek_punct('[')) {
        if (!p.bytes(&s.bytes)) return std::nullopt;
        if (kw == "write" && s.bytes.empty()) {
          p.fail("a write needs at least one byte");
          return std::nullopt;
        }
      }
    }
    s.text = p.text().substr(start, p.offset() - start);
    while (!s.text.empty() && s.text.back() == ' ') s.text.pop_back();
    if (!p.arrow()) return std::nullopt;
    if (!parse_expect(p, &s.expect)) return std::nullopt;
    return s;
  }
  p.fail_at(loc, fmt::format("unknown statement '{}' (expected task, job, at, after, sensor, send, "
                             "write, read or smbus)",
                             kw));
  return std::nullopt;
}

}  // namespace

std::optional<int> errno_from_name(const std::string& name) {
  static const std::pair<const char*, int> kNames[] = {
      {"EPERM", 1},   {"EIO", 5},    {"EBADF", 9},  {"EAGAIN", 11},
      {"EACCES", 13}, {"EBUSY", 16}, {"EINVAL", 22}};
  for (const auto& [n, v] : kNames) {
    if (name == n) return v;
  }
  return std::nullopt;
}

ParseResult parse_test_file(const std::string& file_name, const std::string& text) {
  ParseResult r;
  r.file.file_name = file_name;
  std::vector<Line> lines = lex(text, r.errors);
  TestCase* open = nullptr;
  for (const Line& line : lines) {
    if (line.tokens.empty()) continue;
    LineParser p(line, r.errors);
    if (p.peek_word("test")) {
      std::string kw;
      p.word(&kw, "");
      TestCase c;
      c.loc = line.tokens[0].loc;
      if (open != nullptr) {
        p.fail_at(c.loc, fmt::format("test \"{}\" is not closed: expected '}}' before a new test",
                                     open->name));
        open = nullptr;
      }
      if (!p.string(&c.name, "the test name in quotes")) continue;
      if (!p.punct('{')) continue;
      if (!p.at_end()) {
        p.fail(fmt::format("expected end of line after '{{', found {}", p.found()));
        continue;
      }
      for (const TestCase& other : r.file.cases) {
        if (other.name == c.name) {
          r.errors.push_back(
              {c.loc, fmt::format("test \"{}\" already defined at line {}", c.name, other.loc.line),
               ""});
        }
      }
      r.file.cases.push_back(std::move(c));
      open = &r.file.cases.back();
      continue;
    }
    if (p.peek_punct('}')) {
      const Loc brace = p.here();
      p.punct('}');
      if (open == nullptr) {
        p.fail_at(brace, "'}' without an open test");
      } else if (!p.at_end()) {
        p.fail(fmt::format("expected end of line after '}}', found {}", p.found()));
      }
      open = nullptr;
      continue;
    }
    std::optional<Action> a = parse_statement(p);
    if (!a) continue;
    if (open != nullptr) {
      open->actions.push_back(std::move(*a));
    } else if (std::holds_alternative<Step>(*a)) {
      r.errors.push_back({std::get<Step>(*a).loc,
                          "a bus step outside a test (expected test \"NAME\" { ... })", ""});
    } else {
      r.file.defaults.push_back(std::move(*a));
    }
  }
  if (open != nullptr) {
    r.errors.push_back(
        {open->loc, fmt::format("test \"{}\" is not closed (expected '}}')", open->name), ""});
  }
  if (r.file.cases.empty() && r.errors.empty()) {
    r.errors.push_back({Loc{1, 1}, "no test cases (expected test \"NAME\" { ... })", ""});
  }
  for (ParseError& e : r.errors) {
    e.rendered = fmt::format("{}:{}:{}: error: {}", file_name, e.loc.line, e.loc.column, e.message);
  }
  std::stable_sort(r.errors.begin(), r.errors.end(), [](const ParseError& a, const ParseError& b) {
    return a.loc.line != b.loc.line ? a.loc.line < b.loc.line : a.loc.column < b.loc.column;
  });
  return r;
}

}  // namespace contego::policytest
