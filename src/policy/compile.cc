#include "policy/compile.h"

#include <fmt/format.h>
#include <fstream>
#include <memory>
#include <sstream>

#include "contego/core/checker.h"

#include "base/read_file.h"
#include "policy/check/check.h"
#include "policy/diag/diag.h"
#include "policy/lex/lex.h"
#include "policy/lower/lower.h"
#include "policy/parse/parse.h"

namespace contego::policy {
namespace {

const char* section_name(uint32_t kind) {
  switch (static_cast<core::SectionKind>(kind)) {
    case core::SectionKind::kTasks:
      return "tasks";
    case core::SectionKind::kDevices:
      return "devices";
    case core::SectionKind::kAliases:
      return "aliases";
    case core::SectionKind::kCommands:
      return "commands";
    case core::SectionKind::kFields:
      return "fields";
    case core::SectionKind::kSignals:
      return "signals";
    case core::SectionKind::kRates:
      return "rates";
    case core::SectionKind::kInvariants:
      return "invariants";
    case core::SectionKind::kTemplates:
      return "templates";
    case core::SectionKind::kCode:
      return "code";
    case core::SectionKind::kConstants:
      return "constants";
    case core::SectionKind::kAccess:
      return "access";
    case core::SectionKind::kRegisterInit:
      return "register-init";
    case core::SectionKind::kNames:
      return "names";
  }
  return kind == 0 ? "header" : "unknown";
}

PolicySummary summarize(const CheckedPolicy& p, const SourceBuffer& src,
                        const image::ImageModel* model) {
  PolicySummary s;
  for (const Device& d : p.devices) {
    PolicySummary::Device out;
    out.name = d.name;
    out.profile = d.profile.name;
    const bool act = d.role & core::kRoleActuator, sen = d.role & core::kRoleSensor;
    out.role = act && sen ? "actuator+sensor" : act ? "actuator" : "sensor";
    out.bus = d.bus;
    out.addr = d.addr;
    for (const CommandValue& cv : d.safe) {
      out.safe.push_back(one_line(src.text().substr(cv.span.begin, cv.span.end - cv.span.begin)));
    }
    if (d.latch_count) {
      const uint32_t w = d.latch_window_us;
      out.latch = fmt::format("after {} {}violations within {}", d.latch_count,
                              d.latch_unrepaired ? "unrepaired " : "",
                              w % 1000000 == 0 ? fmt::format("{}s", w / 1000000)
                              : w % 1000 == 0  ? fmt::format("{}ms", w / 1000)
                                               : fmt::format("{}us", w));
    }
    s.devices.push_back(std::move(out));
  }
  for (const Task& t : p.tasks) {
    s.tasks.push_back(
        {t.name, t.exe, t.user, t.group, t.unit, t.cgroup, t.sessions, t.phase_us, t.ignore_errno});
  }
  for (size_t i = 0; i < p.signals.size(); ++i) {
    const Signal& sig = p.signals[i];
    if (sig.raw) {
      const std::string source = p.devices[sig.device].name + "." +
                                 p.devices[sig.device].profile.sample_fields[sig.sample_field].name;
      s.signals.push_back(
          sig.name == source
              ? fmt::format("{} (raw sample value, valid {}..{})", sig.name, sig.lo, sig.hi)
              : fmt::format("{} = {} (raw sample value, valid {}..{})", sig.name, source, sig.lo,
                            sig.hi));
    } else {
      const uint32_t len =
          model && i < model->signals.size() ? model->signals[i].record.code_len : 0;
      s.signals.push_back(
          fmt::format("{} = derived, {} ({} instructions)", sig.name, type_phrase(sig.type), len));
    }
  }
  for (const auto& [name, id] : p.signal_aliases) {
    s.signals.push_back(fmt::format("{} = {}", name, p.signals[id].name));
  }
  for (const RateLimit& r : p.rates) s.rates.push_back(r.text);
  for (const Invariant& i : p.invariants) s.invariants.push_back(i.text);
  return s;
}

}  // namespace

CompileOutput compile_source(const std::string& file_name, const std::string& text,
                             const CompileOptions& options) {
  CompileOutput out;
  SourceBuffer source(file_name, text);
  DiagnosticEmitter diags(source);
  const std::vector<Token> tokens = lex(source, diags);
  const ast::File file = parse(tokens, diags);
  ProfileLookup profiles = options.profiles;
  if (!profiles) profiles = [](std::string_view n) { return devices::find_builtin_profile(n); };
  const CheckedPolicy policy = check(file, source, diags, profiles);
  if (diags.error_count() == 0) {
    LowerResult lowered = lower(policy, diags);
    if (lowered.ok) {
      out.image = image::serialize(lowered.model);
      out.estimated_cost = lowered.estimated_cost;
      auto checker = std::make_unique<core::Checker>();
      const core::LoadResult r =
          checker->load(out.image.data(), static_cast<uint32_t>(out.image.size()));
      if (r.status != core::LoadStatus::kOk) {
        diags.emit(DiagKind::kVerifierRefused, Span{}, core::load_status_name(r.status),
                   section_name(r.section), r.index);
        out.image.clear();
      } else {
        out.worst_case_cost = checker->worst_case_cost();
      }
      if (options.task_model_check && !out.image.empty()) {
        for (const TaskFinding& f : options.task_model_check(lowered.model)) {
          Span at{};
          for (const Task& t : policy.tasks) {
            if (t.name == f.task || (f.task.empty() && at.end == 0)) at = t.span;
          }
          diags.emit(DiagKind::kSchedulabilityWarning, at, f.message);
        }
      }
      out.summary = summarize(policy, source, &lowered.model);
      out.model = std::move(lowered.model);
      for (const Device& d : policy.devices) out.profiles.push_back(d.profile);
    }
  }
  if (out.summary.devices.empty() && out.summary.tasks.empty()) {
    out.summary = summarize(policy, source, nullptr);
  }
  out.ok = diags.error_count() == 0 && !out.image.empty() &&
           !(options.strict && diags.warning_count() > 0);
  out.diagnostics = diags.take();
  return out;
}

CompileOutput compile_file(const std::string& path, const CompileOptions& options) {
  Result<std::string> text = read_input_file(path);
  if (!text) {
    CompileOutput out;
    SourceBuffer source(path, "");
    DiagnosticEmitter diags(source);
    // The message names the path already; the diagnostic names it once.
    std::string why = text.error();
    if (why.starts_with(path + ": ")) why.erase(0, path.size() + 2);
    diags.emit(DiagKind::kCannotRead, Span{}, path, why);
    out.diagnostics = diags.take();
    return out;
  }
  return compile_source(path, *text, options);
}

}  // namespace contego::policy
