// Diagnostics of the policy compiler: the kind registry (diag_kinds.def), an
// emitter that every phase reports through, and renderers (text for people,
// JSON for tools). A diagnostic is "your policy is wrong", never an exception
// or a Result error: the compiler keeps going and reports everything it can.
#ifndef CONTEGO_POLICY_DIAG_DIAG_H_
#define CONTEGO_POLICY_DIAG_DIAG_H_

#include <cstdint>
#include <fmt/format.h>
#include <string>
#include <string_view>
#include <vector>

#include "policy/diag/diagnostic.h"
#include "policy/source/source.h"

namespace contego::policy {

enum class Severity : uint8_t { kError, kWarning, kNote };

enum class DiagKind : uint16_t {
#define CONTEGO_DIAG(name, id, severity, format) k##name,
#include "policy/diag/diag_kinds.def"
#undef CONTEGO_DIAG
  kCount
};

struct DiagKindInfo {
  const char* name;  // "UnknownName"
  const char* id;    // "E0301"
  Severity severity;
  const char* format;  // fmt format string with positional arguments
};

const DiagKindInfo& diag_info(DiagKind kind);
std::string_view severity_name(Severity severity);

// Collects diagnostics for one source buffer. Arguments are formatted with
// fmt at emit time; positions are byte spans converted to line:column here.
class DiagnosticEmitter {
 public:
  explicit DiagnosticEmitter(const SourceBuffer& source) : source_(source) {}

  template <typename... Args>
  void emit(DiagKind kind, Span at, const Args&... args) {
    add(kind, at, fmt::format(fmt::runtime(diag_info(kind).format), args...), false);
  }
  // Attaches a note to the diagnostic emitted last.
  template <typename... Args>
  void note(DiagKind kind, Span at, const Args&... args) {
    add(kind, at, fmt::format(fmt::runtime(diag_info(kind).format), args...), true);
  }

  uint32_t error_count() const { return errors_; }
  uint32_t warning_count() const { return warnings_; }

  // All diagnostics sorted by position (notes stay with their diagnostic).
  std::vector<Diagnostic> take();

 private:
  void add(DiagKind kind, Span at, std::string message, bool is_note);

  const SourceBuffer& source_;
  std::vector<Diagnostic> diags_;
  std::vector<uint32_t> offsets_;  // begin offset of each entry of diags_, for sorting
  uint32_t errors_ = 0;
  uint32_t warnings_ = 0;
};

// file:line:col: severity[ID]: message, the source line and a caret line.
std::string render_text(const Diagnostic& diagnostic);
// Renders every diagnostic (with its notes) as text, one after the other.
std::string render_text(const std::vector<Diagnostic>& diagnostics);
// A JSON array: [{"id","name","severity","file","line","column","end_column","message",
// "notes":[...]}].
std::string render_json(const std::vector<Diagnostic>& diagnostics);

// Every registered kind, in registry order (for the coverage test and docs).
std::vector<DiagKind> all_diag_kinds();

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_DIAG_DIAG_H_
