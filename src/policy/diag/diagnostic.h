// One finding of the policy compiler as tools and people receive it: where,
// how severe, the message and its rendering. Every phase reports these
// through diag.h's emitter; compile.h hands them to callers.
#ifndef CONTEGO_POLICY_DIAG_DIAGNOSTIC_H_
#define CONTEGO_POLICY_DIAG_DIAGNOSTIC_H_

#include <cstdint>
#include <string>
#include <vector>

namespace contego::policy {

struct Diagnostic {
  std::string id;        // stable id, e.g. "E0103"
  std::string name;      // registry name, e.g. "UnknownName"
  std::string severity;  // "error" | "warning" | "note"
  std::string file;
  uint32_t line = 0;        // 1-based
  uint32_t column = 0;      // 1-based
  uint32_t end_column = 0;  // last column the caret covers on `line` (>= column)
  std::string message;
  std::string source_line;  // the text of `line`
  std::string rendered;     // file:line:col: severity[ID]: message + source line + caret (+ notes)
  std::vector<Diagnostic> notes;  // secondary locations ("declared here")
};

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_DIAG_DIAGNOSTIC_H_
