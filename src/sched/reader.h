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

#include <map>
#include <optional>
#include <string>

#include "base/result.h"
#include "sched/task_set.h"

namespace contego::sched {

// `first_line` is the line number of text's first line in its source (a
// block inside a --batch stream), so errors name the stream's line.
Result<TaskSet> parse_csv(const std::string& text, const std::string& source, int first_line = 1);
Result<TaskSet> parse_json(const std::string& text, const std::string& source);

// The set in the JSON form parse_json reads, on one line ending in '\n' (a
// line of a `contego sched --batch` stream): every field of every task,
// durations in ns; no set-wide overhead.
std::string to_json_line(const TaskSet& set);

// By extension (.csv, .json), else by content (a leading '{' is JSON).
// The result has passed validate().
Result<TaskSet> read_task_set_file(const std::string& path);

// {"overhead_ns": 41000, "statistic": "p999", "statistics_ns": {"median":
// 9000, "p99": 23000, "p999": 41000, "max": 1300000}, "measured_on": "...",
// "method": "..."}. statistic and statistics_ns are optional (files of
// older benches carry overhead_ns alone).
struct MeasuredOverhead {
  Nanos overhead = 0;
  std::string statistic;                    // which of statistics overhead_ns is
  std::map<std::string, Nanos> statistics;  // name -> added ns per command
  std::string measured_on;
  std::string method;
};
Result<MeasuredOverhead> parse_overhead_json(const std::string& text, const std::string& source);
Result<MeasuredOverhead> read_overhead_file(const std::string& path);

// The statistic `contego sched --overhead-from` uses when --stat is not given.
inline constexpr const char* kDefaultOverheadStatistic = "p999";

struct ChosenOverhead {
  Nanos overhead = 0;
  std::string statistic;       // its name ("overhead_ns" for a file without statistics)
  std::optional<Nanos> worst;  // the file's "max", shown beside the choice
};
// `wanted` empty: kDefaultOverheadStatistic when the file has it, else
// overhead_ns. Otherwise that statistic, or an error naming the ones there.
Result<ChosenOverhead> choose_overhead(const MeasuredOverhead& m, const std::string& wanted,
                                       const std::string& source);

Result<std::string> read_text_file(const std::string& path);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_READER_H_
