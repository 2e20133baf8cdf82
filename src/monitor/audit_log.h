// The monitor's audit log: one JSON object per line, written and flushed
// before the decision it records takes effect on the bus, so a monitor that
// is killed loses nothing it already decided. docs/audit-format.md describes
// the fields. Thread-safety: internally locked.
#ifndef CONTEGO_MONITOR_AUDIT_LOG_H_
#define CONTEGO_MONITOR_AUDIT_LOG_H_

#include <cstdio>
#include <mutex>
#include <string>

#include "contego/core/verdict.h"

#include "base/result.h"

namespace contego::monitor {

class AuditLog {
 public:
  AuditLog() = default;  // discards everything
  ~AuditLog();
  AuditLog(const AuditLog&) = delete;
  AuditLog& operator=(const AuditLog&) = delete;

  // Appends to `path` ("-" = standard error).
  Status open(const std::string& path);
  void decision(const core::AuditRecord& record, const char* task_name);
  // Monitor events: start, safe-state, fault, task-exit, peer ...
  void event(const std::string& kind, const std::string& detail);
  uint64_t lines() const;

 private:
  void write_line(const std::string& line);
  mutable std::mutex mu_;
  FILE* file_ = nullptr;
  bool owned_ = false;
  uint64_t lines_ = 0;
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_AUDIT_LOG_H_
