// The parser: tokens to an ast::File. Recursive descent with an explicit
// nesting limit (kMaxNesting) so hostile input cannot exhaust the stack.
// Errors are reported through the emitter; after one, the parser skips to
// the next statement (a statement keyword at the start of a line, or the next
// item of a block) and goes on, so one run reports every syntax error.
#ifndef CONTEGO_POLICY_PARSE_PARSE_H_
#define CONTEGO_POLICY_PARSE_PARSE_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "policy/diag/diag.h"
#include "policy/lex/lex.h"
#include "policy/parse/ast.h"

namespace contego::policy {

inline constexpr int kMaxNesting = 32;
// An expression tree at most this tall (a chain of 256 operators), and sets
// and lists of at most this many elements: the passes after the parser
// recurse over the tree, and no program holds more than 512 instructions.
inline constexpr uint32_t kMaxExprHeight = 256;
inline constexpr size_t kMaxElements = 256;

ast::File parse(const std::vector<Token>& tokens, DiagnosticEmitter& diags);

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_PARSE_PARSE_H_
