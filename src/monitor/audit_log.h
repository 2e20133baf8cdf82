// The monitor's audit log: one JSON object per line, in the page cache
// before the decision it records takes effect on the bus, so a monitor that
// is killed loses nothing it already decided. A regular file is mapped and
// extended with zeros ahead of the writer (a record costs a memcpy, no
// system call and no page fault: a helper thread grows the file and faults
// its pages in ahead of the writer; a clean close cuts the padding off, a
// killed monitor leaves it and open() and verify_audit skip it); other files get one write(2) per
// line. The line is formatted with fmt into a buffer the log keeps (no JSON
// library, no stdio, no allocation per decision once the buffer has grown). Every line carries
// "prev", the SHA-256 of the previous line's bytes, so an edited, removed or inserted line breaks
// the chain (verify_audit, `contego audit`). docs/audit-format.md describes the fields.
// Thread-safety: internally locked.
#ifndef CONTEGO_MONITOR_AUDIT_LOG_H_
#define CONTEGO_MONITOR_AUDIT_LOG_H_

#include <atomic>
#include <condition_variable>
#include <istream>
#include <map>
#include <mutex>
#include <string>
#include <sys/types.h>
#include <thread>
#include <utility>
#include <vector>

#include "contego/core/verdict.h"

#include "base/result.h"

namespace contego::monitor {

class AuditLog {
 public:
  AuditLog() = default;  // discards everything
  ~AuditLog();
  AuditLog(const AuditLog&) = delete;
  AuditLog& operator=(const AuditLog&) = delete;

  // Appends to `path` ("-" = standard error), continuing the hash chain from
  // the file's last line.
  Status open(const std::string& path);
  void decision(const core::AuditRecord& record, const char* task_name);
  // Monitor events: start, safe-state, fault, task-exit, peer ...
  void event(const std::string& kind, const std::string& detail);
  uint64_t lines() const;

 private:
  // Appends ,"prev":"..."} and the newline to line_, hashes, writes. mu_ held.
  void finish_line_locked();
  // Maps the file from `pos` with room for `need` more bytes, extending it
  // with zeros in kMapChunk steps. False (and unmapped) on failure.
  bool map_from_locked(off_t pos, size_t need);
  bool extend_locked(size_t upto);  // the file backs the window up to `upto`; grow_mu_ held
  bool grow_locked(size_t upto);    // extended and faulted in up to `upto`; grow_mu_ held
  void grow_ahead();                // the grower thread
  static constexpr size_t kWindow = size_t{256} << 20;  // mapped at once (address space only)
  static constexpr size_t kMapChunk = 1 << 20;          // the file grows by this much
  static constexpr size_t kPrefault = 64 * 1024;        // pages faulted in per step
  static constexpr size_t kAhead = 256 * 1024;          // kept ready ahead of the writer
  mutable std::mutex mu_;
  char prev_[65] = {};  // SHA-256 (hex) of the last line written, NUL-terminated
  std::string line_;    // reused: the line being formatted
  int fd_ = -1;
  bool owned_ = false;
  char* map_ = nullptr;  // the mapped window of a regular file, or null (write(2))
  off_t map_base_ = 0;   // file offset of map_[0]
  size_t map_len_ = 0;
  off_t pos_ = 0;  // file offset of the next record when mapped
  uint64_t lines_ = 0;
  // The grower: extends the file and faults its pages in ahead of the
  // writer. Lock order: mu_, then grow_mu_. The writer's fast path takes
  // no lock but mu_: it writes below ready_ only.
  std::mutex grow_mu_;
  std::condition_variable grow_cv_;
  std::thread grower_;
  bool grow_stop_ = false;                         // grow_mu_
  size_t file_room_ = 0;                           // window bytes the file backs; grow_mu_
  bool prefault_ = true;                           // MADV_POPULATE_WRITE works; grow_mu_
  std::vector<std::pair<char*, size_t>> retired_;  // old windows to unmap; grow_mu_
  std::atomic<size_t> ready_{0};    // window bytes the writer may fill without a fault
  std::atomic<size_t> written_{0};  // window bytes filled so far
};

// The "prev" of the first line of a new log.
inline constexpr const char* kAuditGenesis =
    "0000000000000000000000000000000000000000000000000000000000000000";

struct AuditSummary {
  uint64_t lines = 0;
  uint64_t decisions = 0;
  std::map<std::string, uint64_t> by_decision;  // allow, ignore, failsafe, reject
  std::map<std::string, uint64_t> by_task;      // task name (or id) -> decisions
  std::map<std::string, uint64_t> events;       // start, safe-state, ... -> count
  uint64_t first_us = 0, last_us = 0;
  bool starts_at_genesis = false;  // else it continues a rotated-away log
  bool torn_tail = false;          // the last record was cut off by a killed monitor
  std::string last_hash;           // anchor: SHA-256 of the last line
};

struct AuditCheck {
  bool ok = true;
  uint64_t bad_line = 0;  // 1-based, when !ok
  std::string error;
  AuditSummary summary;  // of the lines up to the first bad one
};

// Verifies the chain line by line and summarises the log.
AuditCheck verify_audit(std::istream& in);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_AUDIT_LOG_H_
