// Task-set files for `contego sched`, and the measured-overhead file written
// by `contego bench`. Formats are specified in docs/sched.md.
//
// CSV: a header naming the columns (any order) from name, wcet, period,
// deadline, priority, actuations, overhead; name, wcet and period are
// required. Durations carry units ("1ms", "250us", "2.5ms"). Blank lines and
// lines starting with '#' are ignored. An empty deadline means D = T.
//
// JSON: {"overhead": "20us", "tasks": [{"name": "t1", "wcet": "1ms",
// "period": "4ms", "deadline": "4ms", "priority": 3, "actuations": 1}]}.
//
// Errors name the file, the line (CSV) or task, and the field.
// Host code.
#ifndef CONTEGO_SCHED_READER_H_
#define CONTEGO_SCHED_READER_H_

#include <string>

#include "base/result.h"
#include "sched/task_set.h"

namespace contego::sched {

Result<TaskSet> parse_csv(const std::string& text, const std::string& source);
Result<TaskSet> parse_json(const std::string& text, const std::string& source);

// By extension (.csv, .json), else by content (a leading '{' is JSON).
// The result has passed validate().
Result<TaskSet> read_task_set_file(const std::string& path);

// {"overhead_ns": 41000, "measured_on": "...", "method": "..."}
struct MeasuredOverhead {
  Nanos overhead = 0;
  std::string measured_on;
  std::string method;
};
Result<MeasuredOverhead> parse_overhead_json(const std::string& text, const std::string& source);
Result<MeasuredOverhead> read_overhead_file(const std::string& path);

Result<std::string> read_text_file(const std::string& path);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_READER_H_
