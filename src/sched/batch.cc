#include "sched/batch.h"

#include <fmt/format.h>
#include <istream>
#include <iterator>
#include <ostream>

#include "sched/analysis.h"
#include "sched/reader.h"
#include "sched/sensitivity.h"

namespace contego::sched {
namespace {

void append_json_string(fmt::memory_buffer& b, std::string_view s) {
  b.push_back('"');
  for (const char c : s) {
    switch (c) {
      case '"':
        fmt::format_to(std::back_inserter(b), "\\\"");
        break;
      case '\\':
        fmt::format_to(std::back_inserter(b), "\\\\");
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          fmt::format_to(std::back_inserter(b), "\\u{:04x}", static_cast<unsigned>(c));
        } else {
          b.push_back(c);
        }
    }
  }
  b.push_back('"');
}

void append_figure(fmt::memory_buffer& b, int64_t v) {
  if (v == kUnbounded) {
    fmt::format_to(std::back_inserter(b), "\"unbounded\"");
  } else if (v == kInfeasible) {
    fmt::format_to(std::back_inserter(b), "\"infeasible\"");
  } else {
    fmt::format_to(std::back_inserter(b), "{}", v);
  }
}

class Batch {
 public:
  Batch(const std::string& source, const BatchOptions& o, std::ostream& out, std::ostream* errors)
      : source_(source), options_(o), out_(out), errors_(errors) {}

  // One set: `text` is a JSON line or a CSV block starting at `line`.
  void one(size_t line, const std::string& text, bool json) {
    const std::string where = source_ + ":" + std::to_string(line);
    summary.parsed_bytes += text.size();
    Result<TaskSet> set =
        json ? parse_json(text, where) : parse_csv(text, source_, static_cast<int>(line));
    if (!set) return error(line, set.error());
    TaskSet s = resolve_overheads(std::move(*set), options_.overhead, 0);
    Assignment how = Assignment::kGiven;
    if (options_.assign) {
      how = *options_.assign;
    } else if (!s.priorities_given) {
      return error(line,
                   where + ": the tasks carry no priorities; choose --assign rm, dm or audsley");
    }
    if (how != Assignment::kGiven) s = assign_priorities(s, how).set;
    analyzer_.analyse(s, analysis_);  // reused: no allocation per set
    std::optional<Sensitivity> sens;
    if (options_.sensitivity) sens = sensitivity(s);
    write(line, s, analysis_, sens ? &*sens : nullptr);
  }

  BatchSummary summary;

 private:
  void error(size_t line, const std::string& message) {
    buf_.clear();
    fmt::format_to(std::back_inserter(buf_), "{{\"line\":{},\"error\":", line);
    append_json_string(buf_, message);
    fmt::format_to(std::back_inserter(buf_), "}}\n");
    out_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    if (errors_ != nullptr) *errors_ << message << "\n";
    ++summary.sets;
    ++summary.failed;
  }

  void write(size_t line, const TaskSet& s, const Analysis& a, const Sensitivity* sens) {
    buf_.clear();
    auto it = std::back_inserter(buf_);
    fmt::format_to(it, "{{\"line\":{},\"schedulable\":{}", line, a.schedulable);
    if (sens != nullptr) {
      fmt::format_to(it, ",\"max_overhead_ns\":");
      append_figure(buf_, sens->max_overhead);
    }
    fmt::format_to(it, ",\"tasks\":[");
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      const Task& t = s.tasks[i];
      const TaskResult& r = a.tasks[i];
      fmt::format_to(it, "{}{{\"name\":", i == 0 ? "" : ",");
      append_json_string(buf_, t.name);
      fmt::format_to(it, ",\"priority\":{},\"overhead_ns\":{},\"c_tee_ns\":{},\"blocking_ns\":{}",
                     t.priority, t.overhead, r.c_tee, r.blocking);
      if (r.schedulable) {
        fmt::format_to(it, ",\"response_ns\":{},\"slack_ns\":{},\"schedulable\":true", r.response,
                       r.slack());
      } else {
        fmt::format_to(it, ",\"response_ns\":null,\"response_exceeds_ns\":{},\"schedulable\":false",
                       r.response);
      }
      if (sens != nullptr) {
        const TaskSensitivity& x = sens->tasks[i];
        fmt::format_to(it, ",\"max_overhead_ns\":");
        append_figure(buf_, x.max_overhead);
        fmt::format_to(it, ",\"min_period_ns\":");
        append_figure(buf_, x.min_period);
        fmt::format_to(it, ",\"max_actuations\":");
        append_figure(buf_, x.max_actuations);
      }
      buf_.push_back('}');
    }
    fmt::format_to(it, "]}}\n");
    out_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
    ++summary.sets;
    if (!a.schedulable) ++summary.unschedulable;
  }

  const std::string& source_;
  const BatchOptions& options_;
  std::ostream& out_;
  std::ostream* errors_;
  Analyzer analyzer_;
  Analysis analysis_;
  fmt::memory_buffer buf_;
};

char first_char(const std::string& line) {
  const size_t at = line.find_first_not_of(" \t\r");
  return at == std::string::npos ? '\0' : line[at];
}

}  // namespace

BatchSummary run_batch(std::istream& in, const std::string& source, const BatchOptions& options,
                       std::ostream& out, std::ostream* errors) {
  Batch batch(source, options, out, errors);
  std::string line;
  std::string block;  // the CSV block under way; block_line is its first line in the stream
  size_t block_line = 0;
  size_t line_no = 0;
  auto flush_block = [&] {
    if (block_line != 0) batch.one(block_line, block, false);
    block.clear();
    block_line = 0;
  };
  while (std::getline(in, line)) {
    ++line_no;
    const char c = first_char(line);
    if (c == '{') {
      flush_block();
      batch.one(line_no, line, true);
    } else if (c == '\0') {
      flush_block();
    } else if (block_line == 0 && c == '#') {
      continue;
    } else {
      if (block_line == 0) {
        block_line = line_no;
      }
      block += line;
      block += '\n';
    }
  }
  flush_block();
  return batch.summary;
}

}  // namespace contego::sched
