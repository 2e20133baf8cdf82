// Drops made visible without the audit log: per-task counts of what the core
// decided, and a rate-limited line on standard error (the terminal under
// `contego run`, the journal under the unit) naming the task, the command,
// the verdict and the rule, when a command of a task is ignored, substituted
// or refused. The first such line of a task comes at once; later ones at most
// one per `interval_us`, with how many more were dropped since.
//
// Thread-safety: none; the monitor calls it under its lock.
#ifndef CONTEGO_MONITOR_DROP_REPORT_H_
#define CONTEGO_MONITOR_DROP_REPORT_H_

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>

#include "contego/core/limits.h"
#include "contego/core/verdict.h"

namespace contego::monitor {

struct RecordNames;

struct DecisionCounts {
  uint64_t allowed = 0, ignored = 0, substituted = 0, refused = 0;
  // Of the allowed: register writes held until their group's last register
  // is written (they act then, or are said dropped).
  uint64_t staged = 0;
  // Complain mode: commands the policy would have dropped that acted as sent
  // (counted here only, not as ignored, substituted or refused).
  uint64_t complained = 0;
  uint64_t dropped() const { return ignored + substituted + refused; }
};

class DropReport {
 public:
  explicit DropReport(std::FILE* out = stderr, uint64_t interval_us = 10'000'000)
      : out_(out), interval_us_(interval_us) {}
  // Counts one decision (records of staged writes and of reads count as allowed).
  void note(const core::AuditRecord& record, const RecordNames& names, uint64_t now_us);
  const DecisionCounts& counts(uint16_t task) const;
  // Starts the task's counts afresh (a reload gave its id to another task).
  void forget(uint16_t task) {
    if (task < tasks_.size()) tasks_[task] = PerTask{};
  }
  std::FILE* out() const { return out_; }  // where the lines go (nullptr: nowhere)
  // "N allowed, N ignored, N substituted, N refused" for the task (the
  // allowed followed by "(N staged: ...)" when some were held, and in
  // complain mode, "; N would have been dropped but acted as sent").
  std::string summary(uint16_t task) const;

 private:
  struct PerTask {
    DecisionCounts counts;
    uint64_t reported_at_us = 0;
    uint64_t unreported = 0;
    bool told = false;
  };
  std::FILE* out_;
  uint64_t interval_us_;
  std::array<PerTask, core::kMaxTasks + 1> tasks_{};  // the last: commands of no task
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_DROP_REPORT_H_
