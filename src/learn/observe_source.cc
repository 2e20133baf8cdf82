#include "learn/observe_source.h"

#include <set>

#include "policy/diag/diag.h"
#include "policy/lex/lex.h"
#include "policy/source/source.h"

namespace contego::learn {

std::vector<Statement> split_statements(const std::string& file_name, const std::string& source) {
  static const std::set<std::string> kKeywords = {"const", "device", "signal",    "task",
                                                  "allow", "limit",  "invariant", "overhead"};
  policy::SourceBuffer buffer(file_name, source);
  policy::DiagnosticEmitter diags(buffer);
  const std::vector<policy::Token> tokens = policy::lex(buffer, diags);
  std::vector<Statement> out;
  std::vector<std::pair<uint32_t, uint32_t>> spans;  // statement begin, end of its last token
  int depth = 0;
  for (size_t i = 0; i < tokens.size(); ++i) {
    const policy::Token& t = tokens[i];
    if (t.kind == policy::Tok::kEnd) break;
    if (depth == 0 && t.line_start && t.kind == policy::Tok::kIdent && kKeywords.contains(t.text)) {
      Statement s;
      s.keyword = t.text;
      if (i + 1 < tokens.size() && tokens[i + 1].kind == policy::Tok::kIdent &&
          s.keyword != "allow" && s.keyword != "limit") {
        s.name = tokens[i + 1].text;
      }
      out.push_back(std::move(s));
      spans.emplace_back(t.span.begin, t.span.end);
    }
    if (t.kind == policy::Tok::kLBrace) ++depth;
    if (t.kind == policy::Tok::kRBrace && depth > 0) --depth;
    if (!spans.empty()) spans.back().second = t.span.end;
  }
  uint32_t prev_end = 0;
  for (size_t k = 0; k < out.size(); ++k) {
    auto [begin, end] = spans[k];
    // The statement runs to the end of its last line (a trailing comment).
    while (end < source.size() && source[end] != '\n') ++end;
    if (end < source.size()) ++end;
    // Its comments: the lines between the statement before and it.
    uint32_t line_begin = begin;
    while (line_begin > prev_end && source[line_begin - 1] != '\n') --line_begin;
    out[k].comments = source.substr(prev_end, line_begin - prev_end);
    out[k].text = source.substr(line_begin, end - line_begin);
    prev_end = end;
  }
  return out;
}

}  // namespace contego::learn
