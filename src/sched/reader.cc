#include "sched/reader.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "base/read_file.h"

namespace contego::sched {
namespace {

std::string trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    out.push_back(trim(std::string_view(line).substr(start, comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return out;
}

Result<int64_t> parse_int(const std::string& text, int64_t lo, int64_t hi) {
  int64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) {
    return make_error("'" + text + "' is not an integer");
  }
  if (v < lo || v > hi) {
    return make_error(std::to_string(v) + " is out of range " + std::to_string(lo) + ".." +
                      std::to_string(hi));
  }
  return v;
}

constexpr int64_t kPriorityLimit = 1'000'000'000;
constexpr int64_t kActuationLimit = 1'000'000;

enum class Column { kName, kWcet, kPeriod, kDeadline, kPriority, kActuations, kOverhead };

const std::map<std::string, Column>& column_names() {
  static const std::map<std::string, Column> names = {
      {"name", Column::kName},         {"wcet", Column::kWcet},
      {"period", Column::kPeriod},     {"deadline", Column::kDeadline},
      {"priority", Column::kPriority}, {"actuations", Column::kActuations},
      {"overhead", Column::kOverhead}};
  return names;
}

Result<TaskSet> finish(TaskSet set, const std::string& source) {
  if (Status st = validate(set); !st.ok()) return make_error(source + ": " + st.error());
  return set;
}

}  // namespace

Result<TaskSet> parse_csv(const std::string& text, const std::string& source, int first_line) {
  std::istringstream in(text);
  std::string line;
  int line_no = first_line - 1;
  std::vector<Column> columns;
  bool has_deadline = false;
  TaskSet set;
  set.priorities_given = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string stripped = trim(line);
    if (stripped.empty() || stripped.front() == '#') continue;
    const std::string where = source + ":" + std::to_string(line_no) + ": ";
    std::vector<std::string> fields = split_commas(stripped);
    if (columns.empty()) {
      for (std::string f : fields) {
        std::transform(f.begin(), f.end(), f.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        const auto it = column_names().find(f);
        if (it == column_names().end()) {
          return make_error(where + "unknown column '" + f +
                            "' in the header (expected name, wcet, period, deadline, priority, "
                            "actuations, overhead)");
        }
        if (std::find(columns.begin(), columns.end(), it->second) != columns.end()) {
          return make_error(where + "column '" + f + "' appears twice in the header");
        }
        columns.push_back(it->second);
      }
      for (auto [name, col] : {std::pair{"name", Column::kName}, std::pair{"wcet", Column::kWcet},
                               std::pair{"period", Column::kPeriod}}) {
        if (std::find(columns.begin(), columns.end(), col) == columns.end()) {
          return make_error(where + "the header has no '" + name + "' column");
        }
      }
      has_deadline = std::find(columns.begin(), columns.end(), Column::kDeadline) != columns.end();
      set.priorities_given =
          std::find(columns.begin(), columns.end(), Column::kPriority) != columns.end();
      continue;
    }
    if (fields.size() != columns.size()) {
      return make_error(where + "expected " + std::to_string(columns.size()) + " fields, found " +
                        std::to_string(fields.size()));
    }
    Task t;
    bool deadline_empty = true;
    for (size_t k = 0; k < columns.size(); ++k) {
      const std::string& f = fields[k];
      auto duration = [&](const char* what, Nanos* out) -> Status {
        Result<Nanos> d = parse_duration(f);
        if (!d) return make_error(where + what + ": " + d.error());
        *out = *d;
        return {};
      };
      Status st;
      switch (columns[k]) {
        case Column::kName:
          t.name = f;
          break;
        case Column::kWcet:
          st = duration("wcet", &t.wcet);
          break;
        case Column::kPeriod:
          st = duration("period", &t.period);
          break;
        case Column::kDeadline:
          deadline_empty = f.empty();
          if (!deadline_empty) st = duration("deadline", &t.deadline);
          break;
        case Column::kPriority: {
          Result<int64_t> p = parse_int(f, -kPriorityLimit, kPriorityLimit);
          if (!p) return make_error(where + "priority: " + p.error());
          t.priority = *p;
          break;
        }
        case Column::kActuations: {
          Result<int64_t> a = parse_int(f, 0, kActuationLimit);
          if (!a) return make_error(where + "actuations: " + a.error());
          t.actuations = *a;
          break;
        }
        case Column::kOverhead:
          if (!f.empty()) st = duration("overhead", &t.overhead);
          break;
      }
      if (!st.ok()) return make_error(st.error());
    }
    if (!has_deadline || deadline_empty) t.deadline = t.period;
    set.tasks.push_back(std::move(t));
  }
  if (columns.empty()) return make_error(source + ": no header line");
  return finish(std::move(set), source);
}

Result<TaskSet> parse_json(const std::string& text, const std::string& source) {
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return make_error(source + ": not valid JSON");
  if (!doc.is_object()) return make_error(source + ": the top level must be an object");
  TaskSet set;
  auto duration = [&](const nlohmann::json& v, const std::string& where) -> Result<Nanos> {
    if (v.is_number_integer() && v.get<int64_t>() == 0) return Nanos{0};
    if (!v.is_string()) {
      return make_error(source + ": " + where + ": give a string with a unit, e.g. \"250us\"");
    }
    Result<Nanos> d = parse_duration(v.get<std::string>());
    if (!d) return make_error(source + ": " + where + ": " + d.error());
    return d;
  };
  for (const auto& [key, value] : doc.items()) {
    if (key == "overhead") {
      Result<Nanos> d = duration(value, "overhead");
      if (!d) return make_error(d.error());
      set.overhead = *d;
    } else if (key != "tasks") {
      return make_error(source + ": unknown key '" + key + "' (expected overhead, tasks)");
    }
  }
  if (!doc.contains("tasks") || !doc["tasks"].is_array()) {
    return make_error(source + ": missing \"tasks\" array");
  }
  int with_priority = 0;
  int index = 0;
  for (const nlohmann::json& jt : doc["tasks"]) {
    ++index;
    std::string where = "tasks[" + std::to_string(index - 1) + "]";
    if (!jt.is_object()) return make_error(source + ": " + where + ": not an object");
    if (jt.contains("name") && jt["name"].is_string()) {
      where += " ('" + jt["name"].get<std::string>() + "')";
    }
    Task t;
    bool has_deadline = false;
    for (const auto& [key, value] : jt.items()) {
      const std::string field = where + "." + key;
      if (key == "name") {
        if (!value.is_string()) return make_error(source + ": " + field + ": must be a string");
        t.name = value.get<std::string>();
      } else if (key == "wcet" || key == "period" || key == "deadline" || key == "overhead") {
        Result<Nanos> d = duration(value, field);
        if (!d) return make_error(d.error());
        if (key == "wcet") t.wcet = *d;
        if (key == "period") t.period = *d;
        if (key == "deadline") t.deadline = *d, has_deadline = true;
        if (key == "overhead") t.overhead = *d;
      } else if (key == "priority" || key == "actuations") {
        if (!value.is_number_integer()) {
          return make_error(source + ": " + field + ": must be an integer");
        }
        const auto v = value.get<int64_t>();
        if (key == "priority") {
          if (v < -kPriorityLimit || v > kPriorityLimit) {
            return make_error(source + ": " + field + ": out of range");
          }
          t.priority = v;
          ++with_priority;
        } else {
          if (v < 0 || v > kActuationLimit) {
            return make_error(source + ": " + field + ": out of range 0..1000000");
          }
          t.actuations = v;
        }
      } else {
        return make_error(source + ": " + field + ": unknown key");
      }
    }
    for (const char* required : {"name", "wcet", "period"}) {
      if (!jt.contains(required)) {
        return make_error(source + ": " + where + ": missing \"" + required + "\"");
      }
    }
    if (!has_deadline) t.deadline = t.period;
    set.tasks.push_back(std::move(t));
  }
  if (with_priority != 0 && with_priority != index) {
    return make_error(source + ": some tasks have a priority and some do not");
  }
  set.priorities_given = with_priority != 0;
  return finish(std::move(set), source);
}

Result<std::string> read_text_file(const std::string& path) { return read_input_file(path); }

std::string to_json_line(const TaskSet& set) {
  nlohmann::json j;
  for (const Task& t : set.tasks) {
    j["tasks"].push_back({{"name", t.name},
                          {"wcet", std::to_string(t.wcet) + "ns"},
                          {"period", std::to_string(t.period) + "ns"},
                          {"deadline", std::to_string(t.deadline) + "ns"},
                          {"priority", t.priority},
                          {"actuations", t.actuations},
                          {"overhead", std::to_string(t.overhead) + "ns"}});
  }
  return j.dump() + "\n";
}

Result<TaskSet> read_task_set_file(const std::string& path) {
  Result<std::string> text = read_text_file(path);
  if (!text) return make_error(text.error());
  auto ends_with = [&](std::string_view suffix) {
    return path.size() >= suffix.size() && path.substr(path.size() - suffix.size()) == suffix;
  };
  if (ends_with(".json")) return parse_json(*text, path);
  if (ends_with(".csv")) return parse_csv(*text, path);
  const size_t first = text->find_first_not_of(" \t\r\n");
  if (first != std::string::npos && (*text)[first] == '{') return parse_json(*text, path);
  return parse_csv(*text, path);
}

Result<MeasuredOverhead> parse_overhead_json(const std::string& text, const std::string& source) {
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return make_error(source + ": not a JSON object");
  if (!doc.contains("overhead_ns") || !doc["overhead_ns"].is_number_integer()) {
    return make_error(source + ": missing integer \"overhead_ns\"");
  }
  MeasuredOverhead m;
  m.overhead = doc["overhead_ns"].get<int64_t>();
  if (m.overhead < 0 || m.overhead > kMaxDuration) {
    return make_error(source + ": overhead_ns out of range");
  }
  if (doc.contains("measured_on") && doc["measured_on"].is_string()) {
    m.measured_on = doc["measured_on"].get<std::string>();
  }
  if (doc.contains("method") && doc["method"].is_string()) {
    m.method = doc["method"].get<std::string>();
  }
  if (doc.contains("statistic")) {
    if (!doc["statistic"].is_string())
      return make_error(source + ": \"statistic\" must be a string");
    m.statistic = doc["statistic"].get<std::string>();
  }
  if (doc.contains("statistics_ns")) {
    const nlohmann::json& stats = doc["statistics_ns"];
    if (!stats.is_object()) return make_error(source + ": \"statistics_ns\" must be an object");
    for (const auto& [name, value] : stats.items()) {
      if (!value.is_number_integer() || value.get<int64_t>() < 0 ||
          value.get<int64_t>() > kMaxDuration) {
        return make_error(source + ": statistics_ns." + name +
                          ": must be an integer number of nanoseconds, 0.." +
                          std::to_string(kMaxDuration));
      }
      m.statistics[name] = value.get<int64_t>();
    }
  }
  return m;
}

Result<ChosenOverhead> choose_overhead(const MeasuredOverhead& m, const std::string& wanted,
                                       const std::string& source) {
  ChosenOverhead c;
  if (auto worst = m.statistics.find("max"); worst != m.statistics.end()) c.worst = worst->second;
  const std::string name = wanted.empty() ? kDefaultOverheadStatistic : wanted;
  if (auto it = m.statistics.find(name); it != m.statistics.end()) {
    c.overhead = it->second;
    c.statistic = name;
    return c;
  }
  if (wanted.empty()) {  // an older file: its one figure
    c.overhead = m.overhead;
    c.statistic = m.statistic.empty() ? "overhead_ns" : m.statistic;
    return c;
  }
  if (m.statistics.empty()) {
    return make_error(source +
                      ": has no statistics_ns (only overhead_ns, from an older contego "
                      "bench); drop --stat or measure again");
  }
  std::string names;
  for (const auto& [n, v] : m.statistics) names += (names.empty() ? "" : ", ") + n;
  return make_error(source + ": no statistic '" + wanted + "' (the file has " + names + ")");
}

Result<MeasuredOverhead> read_overhead_file(const std::string& path) {
  Result<std::string> text = read_text_file(path);
  if (!text) return make_error(text.error());
  return parse_overhead_json(*text, path);
}

}  // namespace contego::sched
