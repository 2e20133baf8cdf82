#include "monitor/drop_report.h"

#include <string.h>

#include <fmt/format.h>

#include "contego/core/checker.h"

#include "monitor/audit_log.h"

namespace contego::monitor {

void DropReport::note(const core::AuditRecord& r, const RecordNames& names, uint64_t now_us) {
  PerTask& t = tasks_[r.task < core::kMaxTasks ? r.task : core::kMaxTasks];
  const char* verdict = nullptr;
  std::string ignored_errno;
  if (names.complain && r.decision != core::Decision::kAllow) {
    ++t.counts.complained;
    verdict = r.decision == core::Decision::kIgnore     ? "would be ignored (complain mode: sent)"
              : r.decision == core::Decision::kFailsafe ? "would be replaced (complain mode: sent)"
                                                        : "would be refused (complain mode: sent)";
  } else {
    switch (r.decision) {
      case core::Decision::kAllow:
        ++t.counts.allowed;
        t.counts.staged += r.reason == core::Reason::kStaged ? 1 : 0;
        return;
      case core::Decision::kIgnore:
        ++t.counts.ignored;
        verdict = "ignored (the program was told it succeeded)";
        if (const char* e = strerrorname_np(names.ignore_errno); names.ignore_errno != 0) {
          ignored_errno = fmt::format("ignored (the call failed with {}: the task's ignore_errno)",
                                      e != nullptr ? e : "its errno");
          verdict = ignored_errno.c_str();
        }
        break;
      case core::Decision::kFailsafe:
        ++t.counts.substituted;
        verdict = "replaced by its fail-safe";
        break;
      case core::Decision::kReject:
        ++t.counts.refused;
        verdict = "refused";
        break;
    }
  }
  if (out_ == nullptr) return;
  if (t.told && now_us - t.reported_at_us < interval_us_) {
    ++t.unreported;
    return;
  }
  const auto name = [](const char* s, const char* otherwise) {
    return s != nullptr && *s != '\0' ? s : otherwise;
  };
  std::string more;
  if (t.unreported != 0) more = fmt::format("; {} more dropped since the last line", t.unreported);
  fmt::print(out_, "contego: task {}: {} to {} {}: {}, {}{}\n", name(names.task, "(none)"),
             name(names.command, "a command"), name(names.device, "(no device)"), verdict,
             name(names.rule, "no rule"), core::reason_name(r.reason), more);
  (void)std::fflush(out_);
  t.told = true;
  t.reported_at_us = now_us;
  t.unreported = 0;
}

const DecisionCounts& DropReport::counts(uint16_t task) const {
  return tasks_[task < core::kMaxTasks ? task : core::kMaxTasks].counts;
}

std::string DropReport::summary(uint16_t task) const {
  const DecisionCounts& c = counts(task);
  const std::string held =
      c.staged != 0 ? fmt::format(" ({} staged: held until their group's last register)", c.staged)
                    : "";
  std::string s = fmt::format("{} allowed{}, {} ignored, {} substituted, {} refused", c.allowed,
                              held, c.ignored, c.substituted, c.refused);
  if (c.complained != 0) {
    s +=
        fmt::format("; {} would have been dropped but acted as sent (complain mode)", c.complained);
  }
  return s;
}

}  // namespace contego::monitor
