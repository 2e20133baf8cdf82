#include "learn/audit_trace.h"

#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <tuple>

#include "contego/core/verdict.h"

#include "base/read_file.h"
#include "monitor/audit_log.h"

namespace contego::learn {
namespace {

using json = nlohmann::json;

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string text(const json& j, const char* key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// A decision line as a TraceDecision, or why it cannot be one.
Result<TraceDecision> decision_of(const json& j) {
  TraceDecision d;
  auto number = [&](const char* key, uint64_t max) -> Result<uint64_t> {
    auto it = j.find(key);
    if (it == j.end() || !it->is_number_unsigned() || it->get<uint64_t>() > max) {
      return make_error(fmt::format("`{}` is missing or not a number up to {}", key, max));
    }
    return it->get<uint64_t>();
  };
  d.task = text(j, "task_name");
  if (d.task.empty()) {
    return make_error(
        "a decision without `task_name` (written without the policy's names): its numbers "
        "cannot be mapped to a policy");
  }
  auto t = number("t_us", UINT64_MAX);
  auto job = number("job", UINT32_MAX);
  auto bus = number("bus", 255);
  auto addr = number("addr", 0x3ff);
  auto device = number("device", 0xffff);
  auto command = number("command", 0xffff);
  auto reason = number("reason", 255);
  for (const auto* r : {&t, &job, &bus, &addr, &device, &command, &reason}) {
    if (!r->ok()) return make_error(r->error());
  }
  d.t_us = *t;
  d.job = static_cast<uint32_t>(*job);
  d.bus = static_cast<uint8_t>(*bus);
  d.addr = static_cast<uint16_t>(*addr);
  if (auto tx = j.find("tx"); tx != j.end() && tx->is_number_unsigned()) {
    d.tx = static_cast<int64_t>(tx->get<uint64_t>());
  }
  if (auto mono = j.find("mono_us"); mono != j.end() && mono->is_number_unsigned()) {
    d.mono_us = static_cast<int64_t>(mono->get<uint64_t>());
  }
  d.device = text(j, "device_name");
  d.command = text(j, "command_name");
  if (*device != 0xffff && d.device.empty()) return make_error("a device without `device_name`");
  if (*command != 0xffff && d.command.empty()) {
    return make_error("a command without `command_name`");
  }
  d.decision = text(j, "decision");
  if (d.decision != "allow" && d.decision != "ignore" && d.decision != "failsafe" &&
      d.decision != "reject") {
    return make_error(fmt::format("unknown decision `{}`", d.decision));
  }
  d.reason = text(j, "reason_name");
  d.rule = text(j, "rule_name");
  d.read = d.reason == "read-allowed" || d.reason == "read-denied";
  if (!parse_hex_bytes(text(j, "bytes"), d.bytes)) return make_error("`bytes` is not hex bytes");
  if (auto f = j.find("fields"); f != j.end() && f->is_array()) {
    for (const json& v : *f) {
      if (!v.is_number_integer()) return make_error("a field value is not an integer");
      d.fields.push_back(v.get<int64_t>());
    }
  }
  if (auto i = j.find("index"); i != j.end() && i->is_number_unsigned()) {
    d.index = static_cast<uint32_t>(i->get<uint64_t>());
  }
  d.substitute = text(j, "substitute");
  d.complain = j.value("complain", false);
  if (auto r = j.find("readings"); r != j.end()) {
    if (!r->is_object()) return make_error("`readings` is not an object");
    d.has_readings = true;
    for (const auto& [name, v] : r->items()) {
      SeenReading seen;
      if (!v.is_null()) {
        if (!v.is_object() || !v.contains("age_us") || !v["age_us"].is_number_unsigned() ||
            !parse_hex_bytes(text(v, "bytes"), seen.bytes)) {
          return make_error(fmt::format("reading `{}` is not {{age_us, bytes}}", name));
        }
        seen.present = true;
        seen.age_us = v["age_us"].get<uint64_t>();
      }
      d.readings[name] = std::move(seen);
    }
  }
  return d;
}

// The events whose effect on the checker a replay repeats.
void note_event(const json& j, const std::string& kind, Trace& trace) {
  const std::string detail = text(j, "detail");
  TraceEvent e;
  e.before = trace.decisions.size();
  e.t_us = j.value("t_us", uint64_t{0});
  static const std::regex exited(R"(^task \d+ \(([^)]*)\) exited)");
  static const std::regex reset(R"(^device \d+ \(([^)]*)\) reset by)");
  std::smatch m;
  if (kind == "safe-state") {
    if (std::regex_search(detail, m, exited)) {
      e.kind = TraceEvent::Kind::kSessionEnd;
      e.name = m[1];
    }
    trace.events.push_back(e);
  } else if (kind == "reset" && std::regex_search(detail, m, reset)) {
    e.kind = TraceEvent::Kind::kReset;
    e.name = m[1];
    trace.events.push_back(e);
  } else if (kind == "start") {
    trace.policies.push_back(detail);
  }
}

}  // namespace

bool same_transaction(const TraceDecision& a, const TraceDecision& b) {
  if (a.tx >= 0 || b.tx >= 0) return a.tx == b.tx && a.file == b.file;
  // contego.ko's records: one decision's records share the module's time of
  // it (their t_us is mapped per line and may differ by a microsecond).
  if (a.mono_us >= 0 || b.mono_us >= 0) {
    return std::tie(a.task, a.bus, a.addr, a.bytes, a.mono_us, a.read) ==
           std::tie(b.task, b.bus, b.addr, b.bytes, b.mono_us, b.read);
  }
  return std::tie(a.task, a.bus, a.addr, a.bytes, a.t_us, a.read) ==
         std::tie(b.task, b.bus, b.addr, b.bytes, b.t_us, b.read);
}

bool parse_hex_bytes(const std::string& s, std::vector<uint8_t>& out) {
  out.clear();
  size_t i = 0;
  while (i < s.size()) {
    if (i + 1 >= s.size()) return false;
    const int hi = hex_digit(s[i]), lo = hex_digit(s[i + 1]);
    if (hi < 0 || lo < 0) return false;
    out.push_back(static_cast<uint8_t>(hi * 16 + lo));
    i += 2;
    if (i < s.size()) {
      if (s[i] != ' ' || i + 1 == s.size()) return false;
      ++i;
    }
  }
  return true;
}

Result<Trace> read_trace(const std::vector<std::string>& paths) {
  Trace trace;
  std::string last_hash;
  bool torn = false;  // the file's last record was cut off by a killed writer: it never acted
  for (size_t k = 0; k < paths.size(); ++k) {
    const std::string& path = paths[k];
    if (Status s = require_regular_file(path); !s.ok()) return make_error(s.error());
    {
      std::ifstream in(path);
      if (!in) return make_error(fmt::format("cannot read {}", path));
      const monitor::AuditCheck c = monitor::verify_audit(in, k == 0 ? std::string() : last_hash);
      if (!c.ok) {
        return make_error(
            fmt::format("{}: line {}: {} (not an intact audit log; `contego audit "
                        "{}` says more)",
                        path, c.bad_line, c.error, path));
      }
      last_hash = c.summary.last_hash;
      torn = c.summary.torn_tail;
    }
    std::ifstream in(path);
    std::string line;
    for (uint64_t n = 1; std::getline(in, line); ++n) {
      if (line.empty() || line[0] == '\0') continue;  // a killed writer's zero padding
      const json j = json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.is_object()) {
        if (torn && in.peek() == std::char_traits<char>::eof()) break;
        return make_error(fmt::format("{}:{}: not a JSON object", path, n));
      }
      ++trace.lines;
      const std::string kind = text(j, "kind");
      if (kind != "decision") {
        note_event(j, kind, trace);
        continue;
      }
      if (const int reason = j.value("reason", -1);
          reason >= 0 && reason < 256 && core::is_follow_up(static_cast<core::Reason>(reason))) {
        continue;  // follows another request's verdict
      }
      auto d = decision_of(j);
      if (!d.ok()) return make_error(fmt::format("{}:{}: {}", path, n, d.error()));
      d->file = path;
      d->line = n;
      trace.decisions.push_back(std::move(*d));
    }
  }
  return trace;
}

}  // namespace contego::learn
