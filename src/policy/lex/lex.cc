#include "policy/lex/lex.h"

#include <cctype>
#include <limits>
#include <utility>

namespace contego::policy {
namespace {

__extension__ typedef __int128 i128;  // exact intermediate arithmetic

bool is_ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool is_ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Microseconds per unit, or 0 if `unit` is no unit.
int64_t unit_scale(std::string_view unit) {
  if (unit == "us") return 1;
  if (unit == "ms") return 1000;
  if (unit == "s") return 1000000;
  if (unit == "min") return 60000000;
  return 0;
}

// How the messages name each token. A spelling in backticks is also the text
// of a punctuation token, which the lexer matches in this order: the two-character
// ones first, so `..` wins over `.`.
constexpr std::pair<Tok, std::string_view> kSpellings[] = {
    {Tok::kEnd, "the end of the file"},
    {Tok::kIdent, "a name"},
    {Tok::kInt, "a number"},
    {Tok::kDuration, "a duration"},
    {Tok::kString, "a string"},
    {Tok::kError, "an invalid token"},
    {Tok::kDotDot, "`..`"},
    {Tok::kEq, "`==`"},
    {Tok::kNe, "`!=`"},
    {Tok::kLe, "`<=`"},
    {Tok::kGe, "`>=`"},
    {Tok::kArrow, "`->`"},
    {Tok::kLParen, "`(`"},
    {Tok::kRParen, "`)`"},
    {Tok::kLBrace, "`{`"},
    {Tok::kRBrace, "`}`"},
    {Tok::kLBracket, "`[`"},
    {Tok::kRBracket, "`]`"},
    {Tok::kComma, "`,`"},
    {Tok::kSemi, "`;`"},
    {Tok::kColon, "`:`"},
    {Tok::kDot, "`.`"},
    {Tok::kAssign, "`=`"},
    {Tok::kLt, "`<`"},
    {Tok::kGt, "`>`"},
    {Tok::kPlus, "`+`"},
    {Tok::kMinus, "`-`"},
    {Tok::kStar, "`*`"},
    {Tok::kSlash, "`/`"},
    {Tok::kPercent, "`%`"},
};

class Lexer {
 public:
  Lexer(const SourceBuffer& source, DiagnosticEmitter& diags)
      : text_(source.text()), diags_(diags) {}

  std::vector<Token> run() {
    while (true) {
      skip_space();
      Token t;
      t.line_start = line_start_;
      line_start_ = false;
      const uint32_t begin = pos_;
      if (pos_ >= text_.size()) {
        t.kind = Tok::kEnd;
        t.span = {begin, begin};
        tokens_.push_back(t);
        return std::move(tokens_);
      }
      const char c = text_[pos_];
      if (is_ident_start(c)) {
        while (pos_ < text_.size() && is_ident_char(text_[pos_])) ++pos_;
        t.kind = Tok::kIdent;
        t.text = std::string(text_.substr(begin, pos_ - begin));
      } else if (is_digit(c)) {
        lex_number(t);
      } else if (c == '"') {
        lex_string(t);
      } else {
        lex_punct(t);
      }
      t.span = {begin, pos_};
      tokens_.push_back(std::move(t));
    }
  }

 private:
  void skip_space() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        line_start_ = true;
        ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\r') {
        ++pos_;
      } else if (c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        return;
      }
    }
  }

  void lex_number(Token& t) {
    const uint32_t begin = pos_;
    bool hex = false;
    if (text_[pos_] == '0' && pos_ + 1 < text_.size() &&
        (text_[pos_ + 1] == 'x' || text_[pos_ + 1] == 'X')) {
      hex = true;
      pos_ += 2;
      while (pos_ < text_.size() && std::isxdigit(static_cast<unsigned char>(text_[pos_]))) ++pos_;
    } else {
      while (pos_ < text_.size() && is_digit(text_[pos_])) ++pos_;
    }
    const uint32_t int_end = pos_;
    // A fraction: `1.5` but not the range operator in `1..5`.
    uint32_t frac_begin = 0, frac_end = 0;
    if (!hex && pos_ + 1 < text_.size() && text_[pos_] == '.' && is_digit(text_[pos_ + 1])) {
      ++pos_;
      frac_begin = pos_;
      while (pos_ < text_.size() && is_digit(text_[pos_])) ++pos_;
      frac_end = pos_;
    }
    const uint32_t unit_begin = pos_;
    while (pos_ < text_.size() && is_ident_char(text_[pos_])) ++pos_;
    const std::string_view unit = text_.substr(unit_begin, pos_ - unit_begin);
    const std::string spelling(text_.substr(begin, pos_ - begin));
    const Span span{begin, pos_};
    t.text = spelling;
    t.kind = Tok::kError;

    if ((hex && int_end == begin + 2) || (!unit.empty() && hex)) {
      diags_.emit(DiagKind::kBadNumber, span, spelling);
      return;
    }
    int64_t scale = 1;
    if (!unit.empty()) {
      scale = unit_scale(unit);
      if (scale == 0) {
        if (is_digit(unit[0]) || unit[0] == '_' || unit.size() > 3) {
          diags_.emit(DiagKind::kBadNumber, span, spelling);
        } else {
          diags_.emit(DiagKind::kUnknownUnit, Span{unit_begin, pos_}, std::string(unit));
        }
        return;
      }
    }
    // Integer part.
    i128 value = 0;
    const uint32_t digits_begin = hex ? begin + 2 : begin;
    for (uint32_t i = digits_begin; i < int_end; ++i) {
      const char d = text_[i];
      const int v =
          is_digit(d) ? d - '0' : (std::tolower(static_cast<unsigned char>(d)) - 'a' + 10);
      value = value * (hex ? 16 : 10) + v;
      if (value > std::numeric_limits<int64_t>::max()) {
        diags_.emit(DiagKind::kNumberTooLarge, span, spelling);
        return;
      }
    }
    value *= scale;
    // Fraction: only exact in microseconds.
    if (frac_end > frac_begin) {
      i128 num = 0, den = 1;
      for (uint32_t i = frac_begin; i < frac_end && den < 1000000000000LL; ++i) {
        num = num * 10 + (text_[i] - '0');
        den *= 10;
      }
      if (unit.empty() || (num * scale) % den != 0) {
        diags_.emit(DiagKind::kFractionalNumber, span, spelling);
        return;
      }
      value += num * scale / den;
    }
    if (value > std::numeric_limits<int64_t>::max()) {
      diags_.emit(DiagKind::kNumberTooLarge, span, spelling);
      return;
    }
    t.kind = unit.empty() ? Tok::kInt : Tok::kDuration;
    t.value = static_cast<int64_t>(value);
  }

  void lex_string(Token& t) {
    const uint32_t begin = pos_;
    ++pos_;
    std::string out;
    while (pos_ < text_.size() && text_[pos_] != '"' && text_[pos_] != '\n') {
      if (text_[pos_] == '\\' && pos_ + 1 < text_.size() && text_[pos_ + 1] != '\n') {
        const char e = text_[pos_ + 1];
        out += e == 'n' ? '\n' : e;
        pos_ += 2;
        continue;
      }
      out += text_[pos_++];
    }
    if (pos_ >= text_.size() || text_[pos_] != '"') {
      diags_.emit(DiagKind::kUnterminatedString, Span{begin, pos_});
      t.kind = Tok::kError;
      return;
    }
    ++pos_;
    t.kind = Tok::kString;
    t.text = std::move(out);
  }

  void lex_punct(Token& t) {
    const std::string_view rest = text_.substr(pos_);
    for (const auto& [kind, spelling] : kSpellings) {
      if (!spelling.starts_with('`')) continue;  // a kind of word, not a text to match
      const std::string_view punct = spelling.substr(1, spelling.size() - 2);
      if (rest.starts_with(punct)) {
        t.kind = kind;
        pos_ += static_cast<uint32_t>(punct.size());
        return;
      }
    }
    const char c = text_[pos_];
    // One UTF-8 sequence at most, so the message shows a whole character.
    uint32_t len = 1;
    const auto uc = static_cast<unsigned char>(c);
    if (uc >= 0xC0) len = uc >= 0xF0 ? 4 : uc >= 0xE0 ? 3 : 2;
    len = std::min<uint32_t>(len, static_cast<uint32_t>(text_.size()) - pos_);
    diags_.emit(DiagKind::kUnexpectedCharacter, Span{pos_, pos_ + len},
                std::string(text_.substr(pos_, len)));
    pos_ += len;
    t.kind = Tok::kError;
  }

  std::string_view text_;
  DiagnosticEmitter& diags_;
  uint32_t pos_ = 0;
  bool line_start_ = true;
  std::vector<Token> tokens_;
};

}  // namespace

std::string_view tok_spelling(Tok kind) {
  for (const auto& [k, spelling] : kSpellings) {
    if (k == kind) return spelling;
  }
  return "a token";
}

std::string describe(const Token& token) {
  switch (token.kind) {
    case Tok::kIdent:
    case Tok::kInt:
    case Tok::kDuration:
      return "`" + token.text + "`";
    case Tok::kString:
      return "a string";
    default:
      return std::string(tok_spelling(token.kind));
  }
}

std::vector<Token> lex(const SourceBuffer& source, DiagnosticEmitter& diags) {
  return Lexer(source, diags).run();
}

}  // namespace contego::policy
