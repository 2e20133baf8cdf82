#include "monitor/audit_explain.h"

#include <ctime>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace contego::monitor {
namespace {

using nlohmann::json;

std::string text(const json& j, const char* key, const std::string& fallback = {}) {
  auto it = j.find(key);
  if (it == j.end()) return fallback;
  if (it->is_string()) return it->get<std::string>();
  if (it->is_number()) return std::to_string(it->get<int64_t>());
  return fallback;
}

int64_t number(const json& j, const char* key, int64_t fallback = 0) {
  auto it = j.find(key);
  return it != j.end() && it->is_number_integer() ? it->get<int64_t>() : fallback;
}

// UTC time of day with microseconds: the log's t_us.
std::string clock_text(int64_t t_us) {
  const time_t s = static_cast<time_t>(t_us / 1000000);
  tm parts{};
  gmtime_r(&s, &parts);
  return fmt::format("{:04}-{:02}-{:02} {:02}:{:02}:{:02}.{:06}Z", parts.tm_year + 1900,
                     parts.tm_mon + 1, parts.tm_mday, parts.tm_hour, parts.tm_min, parts.tm_sec,
                     t_us % 1000000);
}

const char* decision_words(const std::string& d) {
  if (d == "allow") return "allowed";
  if (d == "ignore") return "IGNORED (dropped; the task was told it succeeded)";
  if (d == "failsafe") return "REPLACED by a fail-safe command";
  if (d == "reject") return "REJECTED (the task's call failed)";
  return "decided";
}

std::string rule_words(const json& j) {
  const int64_t kind = number(j, "rule_kind");
  const std::string name = text(j, "rule_name", text(j, "rule"));
  switch (kind) {
    case 1:
      return "the access matrix";
    case 2:
      return "rate limit " + name;
    case 3:
      return "invariant " + name;
    case 4:
      return "the device's latch";
    default:
      return {};
  }
}

// `name(f0, f1, ...)`; register-map channels as `name[i]`.
std::string command_words(const json& j) {
  const int64_t command = number(j, "command", 0xFFFF);
  if (command == 0xFFFF) return fmt::format("bytes [{}]", text(j, "bytes"));
  std::string s = text(j, "command_name", "command " + std::to_string(command));
  if (j.contains("index") && number(j, "index") != 0) s += fmt::format("[{}]", number(j, "index"));
  s += "(";
  if (auto it = j.find("fields"); it != j.end() && it->is_array()) {
    for (size_t i = 0; i < it->size(); ++i) {
      if (i) s += ", ";
      s += (*it)[i].is_number() ? std::to_string((*it)[i].get<int64_t>()) : "?";
    }
  }
  return s + ")";
}

}  // namespace

std::string explain_audit_line(const std::string& line) {
  json j = json::parse(line, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return {};
  const std::string when = clock_text(number(j, "t_us"));
  const std::string kind = text(j, "kind");
  if (kind != "decision") {
    return fmt::format("{} event {}: {}", when, kind.empty() ? "?" : kind,
                       text(j, "detail", text(j, "continues")));
  }
  const std::string task = text(j, "task_name", "task " + text(j, "task"));
  const int64_t device_id = number(j, "device", 0xFFFF);
  const std::string device = device_id == 0xFFFF
                                 ? std::string("no device of the policy")
                                 : text(j, "device_name", "device " + std::to_string(device_id));
  std::string out = fmt::format("{} {} (job {}) -> {} at i2c-{} 0x{:02x}: {} {}", when, task,
                                number(j, "job"), device, number(j, "bus"), number(j, "addr"),
                                command_words(j), decision_words(text(j, "decision")));
  const std::string rule = rule_words(j);
  const std::string reason = text(j, "reason_name", "reason " + text(j, "reason"));
  if (!rule.empty()) {
    out += fmt::format(" by {} ({})", rule, reason);
  } else if (reason != "allowed") {
    out += fmt::format(" ({})", reason);
  }
  const bool complain = j.value("complain", false) && text(j, "decision") != "allow";
  if (j.contains("substitute")) {
    out += fmt::format("; {} [{}] instead", complain ? "would have written" : "wrote",
                       text(j, "substitute"));
  }
  if (complain) out += " -- COMPLAIN MODE: not enforced, the command acted as sent";
  return out;
}

}  // namespace contego::monitor
