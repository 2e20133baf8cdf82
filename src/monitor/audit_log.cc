#include "monitor/audit_log.h"

#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>

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

}  // namespace

AuditLog::~AuditLog() {
  if (owned_ && file_ != nullptr) fclose(file_);
}

Status AuditLog::open(const std::string& path) {
  std::lock_guard lock(mu_);
  if (path == "-") {
    file_ = stderr;
    owned_ = false;
    return {};
  }
  FILE* f = fopen(path.c_str(), "ae");
  if (f == nullptr) return make_error("cannot open audit log " + path + ": " + strerror(errno));
  file_ = f;
  owned_ = true;
  return {};
}

void AuditLog::write_line(const std::string& line) {
  std::lock_guard lock(mu_);
  ++lines_;
  if (file_ == nullptr) return;
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
  write_line(j.dump());
}

void AuditLog::event(const std::string& kind, const std::string& detail) {
  nlohmann::json j;
  j["t_us"] = wall_us();
  j["kind"] = kind;
  j["detail"] = detail;
  write_line(j.dump());
}

uint64_t AuditLog::lines() const {
  std::lock_guard lock(mu_);
  return lines_;
}

}  // namespace contego::monitor
