#include "policy/check/check.h"

#include "base/phrase.h"
#include "policy/check/context.h"

namespace contego::policy {

std::string_view type_phrase(Type type) {
  static constexpr PhraseTable<Type> kPhrases[] = {
      {Type::kInt, "a plain number"}, {Type::kDuration, "a duration"}, {Type::kBool, "a boolean"}};
  return phrase_of(type, kPhrases, "invalid");
}

bool CommandValue::constant() const {
  for (const auto& f : fields) {
    if (f.value && !f.value->is_const()) return false;
  }
  return true;
}

std::string to_string(const IExpr& e) {
  static const char* kNames[] = {
      "const", "signal", "field", "last", "since_last", "index", "jobcount", "neg",    "not",
      "abs",   "add",    "sub",   "mul",  "div",        "mod",   "min",      "max",    "eq",
      "ne",    "lt",     "le",    "gt",   "ge",         "and",   "or",       "last_or"};
  std::string out = kNames[static_cast<int>(e.op)];
  if (e.op == IOp::kConst) return std::to_string(e.value);
  if (e.op == IOp::kSignal || e.op == IOp::kField || e.op == IOp::kLastField) {
    out += std::to_string(e.slot);
  }
  if (!e.kids.empty()) {
    out += "(";
    for (size_t i = 0; i < e.kids.size(); ++i) {
      if (i) out += ",";
      out += to_string(*e.kids[i]);
    }
    out += ")";
  }
  return out;
}

CheckedPolicy check(const ast::File& file, const SourceBuffer& source, DiagnosticEmitter& diags,
                    const ProfileLookup& profiles) {
  return check_internal::Sema(file, source, diags, profiles).run();
}

}  // namespace contego::policy
