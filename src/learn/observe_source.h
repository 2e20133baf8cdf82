// The observe policy's text cut into its top-level statements, so that the
// generator keeps what the user declared (constants, devices, signals, with
// their comments) and writes the rest anew.
#ifndef CONTEGO_LEARN_OBSERVE_SOURCE_H_
#define CONTEGO_LEARN_OBSERVE_SOURCE_H_

#include <string>
#include <vector>

namespace contego::learn {

struct Statement {
  std::string keyword;   // const, device, signal, task, allow, limit, invariant, overhead
  std::string name;      // the identifier after the keyword ("" for allow, limit)
  std::string comments;  // the comment and blank lines before it
  std::string text;      // the statement, to the end of its last line
};

// Top-level statements in source order (by the policy lexer: a keyword at the
// start of a line outside any braces). Text after the last one is dropped.
std::vector<Statement> split_statements(const std::string& file_name, const std::string& source);

}  // namespace contego::learn

#endif  // CONTEGO_LEARN_OBSERVE_SOURCE_H_
