#include "policy/diag/diag.h"

#include <algorithm>
#include <nlohmann/json.hpp>
#include <numeric>

#include "base/json_text.h"
#include "base/phrase.h"

namespace contego::policy {
namespace {

constexpr DiagKindInfo kInfos[] = {
#define CONTEGO_DIAG(name, id, severity, format) {#name, id, Severity::severity, format},
#include "policy/diag/diag_kinds.def"
#undef CONTEGO_DIAG
};
static_assert(sizeof(kInfos) / sizeof(kInfos[0]) == static_cast<size_t>(DiagKind::kCount));

// Tabs are shown as one space so that the caret line lines up.
std::string untab(std::string_view text) {
  std::string out(text);
  std::replace(out.begin(), out.end(), '\t', ' ');
  return out;
}

nlohmann::json to_json(const Diagnostic& d) {
  nlohmann::json j = {
      {"id", d.id},     {"name", d.name},     {"severity", d.severity},     {"file", d.file},
      {"line", d.line}, {"column", d.column}, {"end_column", d.end_column}, {"message", d.message}};
  nlohmann::json notes = nlohmann::json::array();
  for (const auto& n : d.notes) notes.push_back(to_json(n));
  j["notes"] = std::move(notes);
  return j;
}

}  // namespace

const DiagKindInfo& diag_info(DiagKind kind) { return kInfos[static_cast<size_t>(kind)]; }

std::string_view severity_name(Severity severity) {
  static constexpr PhraseTable<Severity> kNames[] = {
      {Severity::kError, "error"}, {Severity::kWarning, "warning"}, {Severity::kNote, "note"}};
  return phrase_of(severity, kNames, "error");
}

std::vector<DiagKind> all_diag_kinds() {
  std::vector<DiagKind> kinds;
  for (uint16_t i = 0; i < static_cast<uint16_t>(DiagKind::kCount); ++i) {
    kinds.push_back(static_cast<DiagKind>(i));
  }
  return kinds;
}

void DiagnosticEmitter::add(DiagKind kind, Span at, std::string message, bool is_note) {
  const DiagKindInfo& info = diag_info(kind);
  Diagnostic d;
  d.id = info.id;
  d.name = info.name;
  d.severity = std::string(severity_name(info.severity));
  d.file = source_.file_name();
  const LineCol begin = source_.position(at.begin);
  d.line = begin.line;
  d.column = begin.column;
  // The caret covers the span on its first line (at least one character).
  const std::string_view line = source_.line_text(begin.line);
  uint32_t end_col = begin.column;
  if (at.end > at.begin) {
    const LineCol end = source_.position(at.end);
    end_col = end.line == begin.line ? std::max(begin.column, end.column - 1)
                                     : static_cast<uint32_t>(line.size());
  }
  d.end_column = std::max(end_col, begin.column);
  d.message = std::move(message);
  d.source_line = std::string(line);
  d.rendered = render_text(d);
  if (is_note && !diags_.empty()) {
    diags_.back().notes.push_back(std::move(d));
    diags_.back().rendered = render_text(diags_.back());
    return;
  }
  if (info.severity == Severity::kError) ++errors_;
  if (info.severity == Severity::kWarning) ++warnings_;
  diags_.push_back(std::move(d));
  offsets_.push_back(at.begin);
}

std::vector<Diagnostic> DiagnosticEmitter::take() {
  std::vector<size_t> order(diags_.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return offsets_[a] < offsets_[b]; });
  std::vector<Diagnostic> out;
  out.reserve(order.size());
  for (size_t i : order) out.push_back(std::move(diags_[i]));
  diags_.clear();
  offsets_.clear();
  return out;
}

std::string render_text(const Diagnostic& d) {
  std::string out =
      fmt::format("{}:{}:{}: {}[{}]: {}\n", d.file, d.line, d.column, d.severity, d.id, d.message);
  if (d.line > 0) {
    const std::string number = std::to_string(d.line);
    const std::string gutter(number.size(), ' ');
    out += fmt::format(" {} | {}\n", number, untab(d.source_line));
    const uint32_t width = d.end_column >= d.column ? d.end_column - d.column : 0;
    out += fmt::format(" {} | {}^{}\n", gutter, std::string(d.column - 1, ' '),
                       std::string(width, '~'));
  }
  for (const auto& n : d.notes) out += render_text(n);
  return out;
}

std::string render_text(const std::vector<Diagnostic>& diagnostics) {
  std::string out;
  for (const auto& d : diagnostics) out += render_text(d);
  return out;
}

std::string render_json(const std::vector<Diagnostic>& diagnostics) {
  nlohmann::json arr = nlohmann::json::array();
  for (const auto& d : diagnostics) arr.push_back(to_json(d));
  return json_text(arr, 2);
}

}  // namespace contego::policy
