// What the audit log tells the operator besides the file: one entry per
// decision that is not `allow` and per event, with a syslog priority and the
// names as fields, for the systemd journal (cli/journal_sink.h sends them
// with sd_journal_send). The hash-chained file stays the record of truth;
// these entries are rate-limited and may be lost.
#ifndef CONTEGO_MONITOR_JOURNAL_ENTRY_H_
#define CONTEGO_MONITOR_JOURNAL_ENTRY_H_

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <utility>

namespace contego::monitor {

// syslog(3) priorities, as the journal's PRIORITY= field takes them.
enum class Priority : int { kError = 3, kWarning = 4, kNotice = 5, kInfo = 6 };

struct JournalEntry {
  Priority priority = Priority::kInfo;
  // "decision", "latch" (a decision of the latch rule), "audit-failure", or
  // the audit event's kind ("start", "safe-state", "fault", ...).
  std::string_view kind;
  std::string message;
  // Of a decision: the policy's names (numbers where a name is unknown).
  std::string task, device, command, rule, verdict, reason;
};

using JournalSink = std::function<void(const JournalEntry&)>;

// At most `limit` messages a second: admit() says whether this one goes,
// and take_left_out() how many did not since the last that went.
struct PerSecondLimit {
  unsigned limit;
  uint64_t window_us = 0;  // monotonic: start of the current second
  unsigned sent = 0;
  uint64_t left_out = 0;
  bool admit(uint64_t now_us) {
    if (now_us - window_us >= 1000000) {
      window_us = now_us;
      sent = 0;
    }
    if (sent >= limit) {
      ++left_out;
      return false;
    }
    ++sent;
    return true;
  }
  uint64_t take_left_out() { return std::exchange(left_out, 0); }
};

// An audit event's priority: faults and refused starts are errors, a safe
// state driven or a session refused a warning, a start or a reset a notice.
Priority event_priority(std::string_view kind);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_JOURNAL_ENTRY_H_
