#include "monitor/audit_log.h"

#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>

#include "base/json_text.h"
#include "monitor/sha256.h"

namespace contego::monitor {
namespace {

uint64_t wall_us() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
}

std::string hex(const uint8_t* bytes, uint32_t len) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (uint32_t i = 0; bytes != nullptr && i < len; ++i) {
    if (i) out += ' ';
    out += digits[bytes[i] >> 4];
    out += digits[bytes[i] & 15];
  }
  return out;
}

// Local names so the log does not depend on the core's string tables.
const char* decision_str(core::Decision d) {
  switch (d) {
    case core::Decision::kAllow:
      return "allow";
    case core::Decision::kIgnore:
      return "ignore";
    case core::Decision::kFailsafe:
      return "failsafe";
    case core::Decision::kReject:
      return "reject";
  }
  return "?";
}

std::string fmt_line(uint64_t n, const std::string& why) {
  return "line " + std::to_string(n) + ": " + why;
}

// The last non-empty line of an existing log, or "" (a new log).
std::string last_line(FILE* f) {
  if (fseek(f, 0, SEEK_END) != 0) return {};
  const long size = ftell(f);
  if (size <= 0) return {};
  const long start = size > 65536 ? size - 65536 : 0;
  std::string tail(static_cast<size_t>(size - start), '\0');
  if (fseek(f, start, SEEK_SET) != 0 || fread(tail.data(), 1, tail.size(), f) != tail.size()) {
    return {};
  }
  while (!tail.empty() && tail.back() == '\n') tail.pop_back();
  const size_t nl = tail.rfind('\n');
  return nl == std::string::npos ? tail : tail.substr(nl + 1);
}

}  // namespace

AuditLog::~AuditLog() {
  if (owned_ && file_ != nullptr) fclose(file_);
}

Status AuditLog::open(const std::string& path) {
  std::lock_guard lock(mu_);
  prev_ = kAuditGenesis;
  if (path == "-") {
    file_ = stderr;
    owned_ = false;
    return {};
  }
  FILE* f = fopen(path.c_str(), "a+e");
  if (f == nullptr) return make_error("cannot open audit log " + path + ": " + strerror(errno));
  const std::string last = last_line(f);
  if (!last.empty()) prev_ = sha256_hex(last);
  file_ = f;
  owned_ = true;
  return {};
}

void AuditLog::write_line(nlohmann::json& j) {
  std::lock_guard lock(mu_);
  ++lines_;
  if (file_ == nullptr) return;
  j["prev"] = prev_;
  const std::string line = json_text(j);
  prev_ = sha256_hex(line);
  fputs(line.c_str(), file_);
  fputc('\n', file_);
  fflush(file_);  // on disk (page cache) before the decision acts: survives a killed monitor
}

void AuditLog::decision(const core::AuditRecord& r, const char* task_name) {
  nlohmann::json j;
  j["t_us"] = wall_us();
  j["kind"] = "decision";
  j["task"] = r.task;
  if (task_name != nullptr) j["task_name"] = task_name;
  j["job"] = r.job;
  j["bus"] = r.bus;
  j["addr"] = r.addr;
  j["device"] = r.device;
  j["command"] = r.command;
  j["decision"] = decision_str(r.decision);
  j["reason"] = static_cast<int>(r.reason);
  j["rule_kind"] = static_cast<int>(r.rule_kind);
  j["rule"] = r.rule;
  j["index"] = r.index;
  std::vector<int32_t> fields(r.fields, r.fields + std::min<uint8_t>(r.field_count, 8));
  j["fields"] = fields;
  j["bytes"] = hex(r.original, r.original_len);
  if (r.substitute != nullptr) j["substitute"] = hex(r.substitute, r.substitute_len);
  write_line(j);
}

void AuditLog::event(const std::string& kind, const std::string& detail) {
  nlohmann::json j;
  j["t_us"] = wall_us();
  j["kind"] = kind;
  j["detail"] = detail;
  write_line(j);
}

uint64_t AuditLog::lines() const {
  std::lock_guard lock(mu_);
  return lines_;
}

AuditCheck verify_audit(std::istream& in) {
  AuditCheck c;
  AuditSummary& s = c.summary;
  std::string line, prev_hash;
  auto fail = [&](const std::string& why) {
    c.ok = false;
    c.bad_line = s.lines + 1;
    c.error = fmt_line(c.bad_line, why);
    return c;
  };
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return fail("not a JSON object");
    if (!j.contains("prev") || !j["prev"].is_string()) return fail("no \"prev\" hash");
    const std::string prev = j["prev"].get<std::string>();
    if (s.lines == 0) {
      s.starts_at_genesis = prev == kAuditGenesis;
    } else if (prev != prev_hash) {
      return fail(
          "\"prev\" is not the SHA-256 of the line before: that line was changed, or "
          "lines were removed or inserted here");
    }
    prev_hash = sha256_hex(line);
    ++s.lines;
    s.last_hash = prev_hash;
    if (j.contains("t_us") && j["t_us"].is_number_unsigned()) {
      const uint64_t t = j["t_us"].get<uint64_t>();
      if (s.first_us == 0) s.first_us = t;
      s.last_us = t;
    }
    const std::string kind = j.value("kind", std::string("?"));
    if (kind == "decision") {
      ++s.decisions;
      ++s.by_decision[j.value("decision", std::string("?"))];
      std::string task = j.contains("task_name") && j["task_name"].is_string()
                             ? j["task_name"].get<std::string>()
                             : (j.contains("task") ? json_text(j["task"]) : std::string("?"));
      ++s.by_task[task];
    } else {
      ++s.events[kind];
    }
  }
  return c;
}

}  // namespace contego::monitor
