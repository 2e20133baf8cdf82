// The lexer: policy text to tokens. Newlines are not tokens; instead each
// token records whether it starts a line, which the parser uses to
// resynchronise after an error. Keywords are contextual (plain identifiers),
// so a device field may be called `on` or `in`.
#ifndef CONTEGO_POLICY_LEX_LEX_H_
#define CONTEGO_POLICY_LEX_LEX_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "policy/diag/diag.h"
#include "policy/source/source.h"

namespace contego::policy {

enum class Tok : uint8_t {
  kEnd,
  kIdent,
  kInt,       // value = the integer
  kDuration,  // value = microseconds
  kString,    // text = contents without quotes (escapes \" \\ \n resolved)
  kLParen,
  kRParen,
  kLBrace,
  kRBrace,
  kLBracket,
  kRBracket,
  kComma,
  kSemi,
  kColon,
  kDot,
  kDotDot,
  kAssign,
  kEq,
  kNe,
  kLt,
  kLe,
  kGt,
  kGe,
  kPlus,
  kMinus,
  kStar,
  kSlash,
  kPercent,
  kArrow,
  kError,  // a lexical error already reported; the parser skips it
};

struct Token {
  Tok kind = Tok::kEnd;
  Span span;
  bool line_start = false;  // first token on its line
  int64_t value = 0;
  std::string text;  // identifiers, strings, the spelling of numbers
};

// Human name for "found ..." messages: "`foo`", "the end of the file", "`{`".
std::string describe(const Token& token);
std::string_view tok_spelling(Tok kind);

std::vector<Token> lex(const SourceBuffer& source, DiagnosticEmitter& diags);

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_LEX_LEX_H_
