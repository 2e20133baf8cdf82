// What a trace shows about each task, device and command: the input of the
// policy generator (learn/generate.h).
#ifndef CONTEGO_LEARN_TRACE_STATS_H_
#define CONTEGO_LEARN_TRACE_STATS_H_

#include <climits>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "base/result.h"
#include "learn/audit_trace.h"
#include "policy/compile.h"

namespace contego::learn {

struct FieldStats {
  int64_t lo = INT64_MAX, hi = INT64_MIN;
  std::set<int64_t> values;  // the first 64 distinct ones
  void add(int64_t v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    if (values.size() < 64) values.insert(v);
  }
};

// One command of one device, over every task that sent it.
struct CommandStats {
  uint64_t acted = 0;
  std::string first_task;
  const TraceDecision* first = nullptr;  // its first record that acted
  std::vector<FieldStats> fields;        // in the command's field order
  std::set<uint32_t> channels;           // register-map groups: the channels written
};

struct TaskDeviceStats {
  bool actuates = false, reads = false;
  uint64_t acting_count = 0, read_count = 0;
  // Per command that acted: the most of it in any window of the task's period.
  std::map<std::string, uint64_t> per_command_window_max;
};

struct TaskStats {
  uint64_t period_us = 0;
  std::string period_source;    // how the period was found, in words
  uint64_t max_per_window = 0;  // commands that acted in any window of one period
  uint64_t actuations = 0;      // with the margin, and at least every rate limit
  std::map<std::string, TaskDeviceStats> devices;
  std::vector<size_t> records;  // its decisions that acted, were staged or read (trace order)
};

struct Suggestion {
  std::string evidence;  // what the trace showed
  std::string rule;      // the invariant, as a policy line
};

struct TraceStats {
  uint64_t first_us = 0, last_us = 0;
  std::map<std::string, TaskStats> tasks;
  std::map<std::pair<std::string, std::string>, CommandStats> commands;  // (device, command)
  std::vector<Suggestion> suggestions;
  std::vector<std::string> findings;
};

// Refuses a trace with no decision that acted (nothing to learn from).
Result<TraceStats> collect_stats(const Trace& trace, const policy::CompileOutput& observed,
                                 uint32_t margin_percent);

// The most of `times` (sorted) inside any half-open window of `window_us`.
uint64_t window_max(const std::vector<uint64_t>& times, uint64_t window_us);

}  // namespace contego::learn

#endif  // CONTEGO_LEARN_TRACE_STATS_H_
