// The monitor's audit log: one JSON object per line, in the page cache
// before the decision it records takes effect on the bus, so a monitor that
// is killed loses nothing it already decided. A regular file is mapped and
// space is allocated (zeros appended) ahead of the writer (a record costs a
// memcpy, no system call and no page fault: a helper thread allocates and
// faults pages in ahead of the writer; a full file system is an error of the
// allocation, seen before a record needs the space, never a SIGBUS; a clean
// close cuts the padding off, a killed monitor leaves it and open() and
// verify_audit skip it); other files (only with `allow_unsafe`) and standard
// error get one write(2) per line.
//
// No action without a record: decision() and event() return false when the
// line is not in the log (no space, an I/O error...); the monitor then
// refuses the action. The file is locked (flock) so that a second writer is
// refused at open, checked every 100 ms for truncation, deletion and
// replacement (and a truncation racing a record is caught: the copy is
// guarded against SIGBUS and retried), rotated by size (`max_bytes`) or on
// reopen() (SIGHUP). Every file after the first starts with a `continues`
// record naming the file it follows; its "prev" is the last hash of that
// file, so the chain runs across files (verify_audit with `continues_from`).
//
// The line is formatted with fmt into a buffer the log keeps (no JSON
// library, no stdio, no allocation per decision once the buffer has grown). Every line carries
// "prev", the SHA-256 of the previous line's bytes, so an edited, removed or inserted line breaks
// the chain (verify_audit, `contego audit`). docs/audit-format.md describes the fields.
// Thread-safety: internally locked.
#ifndef CONTEGO_MONITOR_AUDIT_LOG_H_
#define CONTEGO_MONITOR_AUDIT_LOG_H_

#include <atomic>
#include <condition_variable>
#include <functional>
#include <istream>
#include <map>
#include <string>
#include <sys/types.h>
#include <thread>
#include <utility>
#include <vector>

#include "contego/core/verdict.h"

#include "base/mutex.h"
#include "base/result.h"
#include "monitor/journal_entry.h"

namespace contego::monitor {

struct AuditOptions {
  // Accept a target that is not a regular file (a FIFO, a character device
  // such as /dev/null): one write(2) per line, no lock, no rotation, no
  // space check. /dev/full then fails every record (and every action).
  bool allow_unsafe = false;
  uint64_t max_bytes = 0;  // rotate before a record would take the file past this (0 = never)
  unsigned keep = 5;       // rotated files kept: PATH.1 (newest) .. PATH.keep
  // Also one line on standard error for every decision that is not `allow`
  // (at most 10 a second, then a count of those left out): the monitor under
  // systemd sets it (JOURNAL_STREAM), so violations reach the journal too.
  bool echo_violations = false;
  // The journal (cli/journal_sink.h): when set, those lines go here instead,
  // with priorities and fields, and so does every event (at most 20 a
  // second) and every report of the log's own failure.
  JournalSink journal;
};

// The policy's names of the numbers in a decision record (any may be null:
// the record then carries the number only).
struct RecordNames {
  const char* task = nullptr;
  const char* device = nullptr;
  const char* command = nullptr;
  const char* rule = nullptr;
  // The process that asked, when the writer knows it (contego.ko's records
  // carry it; the monitor binds a connection to a task instead): -1 = not written.
  int64_t pid = -1;
  int64_t uid = -1;
  // When the decision was taken, when the writer is not the decider
  // (contego.ko's records, written later by `contego kmod audit`): the
  // decider's CLOCK_MONOTONIC (`mono_us`) and the wall-clock time it maps to
  // (`t_us`). -1: the writer's own time is the decision's (t_us only).
  int64_t mono_us = -1;
  int64_t t_us = -1;
  // Complain mode: the decision is the policy's, but the command acted as the
  // program sent it (`"complain":true`).
  bool complain = false;
  // The task's `ignore_errno` (0: none): an ignored call failed with it
  // instead of succeeding (the drop report says so).
  uint8_t ignore_errno = 0;
  // The writer's number of the core check the record is of (`tx`): records
  // with one number are one transaction's commands. -1: not written.
  int64_t tx = -1;
  // The sensor readings the decision saw, a JSON object written as is
  // (`readings`: {"line":{"age_us":N,"bytes":"..."}, ...}); null: none.
  const std::string* readings = nullptr;
};

// The policy image's names, by id: what a decision record's numbers mean.
struct NameTable {
  std::vector<std::string> tasks, devices, commands, rates, invariants;
  RecordNames of(const core::AuditRecord& record) const;
};

// The names of an image's records (image::ImageModel, whose record lists
// each carry a `name`), by id.
template <typename Model>
NameTable name_table(const Model& model) {
  auto names = [](const auto& records) {
    std::vector<std::string> v;
    for (const auto& r : records) v.push_back(r.name);
    return v;
  };
  return {names(model.tasks), names(model.devices), names(model.commands), names(model.rates),
          names(model.invariants)};
}

class AuditLog {
 public:
  AuditLog() = default;  // discards everything
  ~AuditLog();
  AuditLog(const AuditLog&) = delete;
  AuditLog& operator=(const AuditLog&) = delete;
  // The thread that keeps a file's pages ready ahead of the writer; it
  // sleeps while the log is idle.
  static constexpr const char* kGrowerThreadName = "audit-grower";

  // Appends to `path` ("-" = standard error), continuing the hash chain from
  // the file's last line. Refuses a target that is not a regular file
  // (unless options.allow_unsafe), a file another writer holds (naming it),
  // and a file system without room for the first records.
  Status open(const std::string& path, const AuditOptions& options = {});
  // False: the line is NOT in the log (the caller must not act on it). A
  // loud, rate-limited message goes to standard error.
  bool decision(const core::AuditRecord& record, const RecordNames& names);
  bool decision(const core::AuditRecord& record, const char* task_name) {
    return decision(record, RecordNames{task_name, nullptr, nullptr, nullptr});
  }
  // Monitor events: start, safe-state, fault, task-exit, peer ...
  bool event(const std::string& kind, const std::string& detail);
  // An event whose detail is made under the log's lock from the chain's
  // anchor at that point: the SHA-256 of the record it will follow and the
  // records written so far (a signed checkpoint). "" from `detail`: nothing
  // is written (false).
  bool anchored_event(
      const std::string& kind,
      const std::function<std::string(const std::string& prev_hash, uint64_t records)>& detail);
  // An event the writer did not see happen (contego.ko's records, written
  // later by `contego kmod audit`): its time as RecordNames's mono_us and
  // t_us (-1: the writer's own time, and no mono_us).
  bool event(const std::string& kind, const std::string& detail, int64_t t_us, int64_t mono_us);
  // SIGHUP: if the path no longer names the open file (moved away by
  // logrotate, deleted), opens the path anew and continues the chain there.
  // With max_bytes set, rotates now. Returns what it did.
  Result<std::string> reopen();
  // Replaces where entries go to the journal (a reload stamps them with the
  // new image's hash).
  void set_journal(JournalSink journal);
  uint64_t lines() const;      // lines written (or discarded: no log)
  uint64_t failures() const;   // records that could not be written
  uint64_t rotations() const;  // files started after the first
  std::string path() const;
  std::string last_hash() const;  // SHA-256 (hex) of the last line: the chain's anchor
  uint64_t position() const;      // the current file's offset past its last record

 private:
  // Appends ,"prev":"..."} and the newline to body, hashes, writes; on
  // success the chain advances. Handles rotation, truncation, deletion and
  // a lost write (a retry after resync).
  bool commit_locked(std::string& body, bool continuation = false) REQUIRES(mu_);
  // The bytes reach the file (or not at all).
  bool put_locked(const std::string& line) REQUIRES(mu_);
  // One stderr line for a decision that is not `allow` (echo_violations).
  void echo_violation_locked(const core::AuditRecord& record, const RecordNames& names)
      REQUIRES(mu_);
  bool write_fd_locked(const std::string& line) REQUIRES(mu_);
  // Opens path_ (the checks of open()) and continues at its end.
  Status open_file_locked() REQUIRES(mu_);
  void close_file_locked() REQUIRES(mu_);  // unmap, cut the padding, unlock, close
  // The file behind fd_ changed (truncated, deleted, replaced)? Then
  // continue accordingly. True if a line was lost or needs a retry.
  void check_file_locked(bool force) REQUIRES(mu_);
  bool rotate_locked(const std::string& why) REQUIRES(mu_);  // PATH -> PATH.1 ..., new PATH
  bool start_continuation_locked(const std::string& follows, const char* old_hash,
                                 const std::string& why) REQUIRES(mu_);
  void report_failure_locked(const std::string& why) REQUIRES(mu_);
  // Maps the file from `pos` with room for `need` more bytes, extending it
  // with zeros in kGrowStep steps. False (and unmapped) on failure.
  bool map_from_locked(off_t pos, size_t need) REQUIRES(mu_, grow_mu_);
  bool extend_locked(size_t upto) REQUIRES(grow_mu_);   // the file backs the window up to `upto`
  bool grow_locked(size_t upto) REQUIRES(grow_mu_);     // extended and faulted in up to `upto`
  void grow_ahead();                                    // the grower thread
  static constexpr size_t kWindow = size_t{256} << 20;  // mapped at once (address space only)
  static constexpr size_t kMapChunk = 1 << 20;          // a window's length is a multiple
  // The file grows by this much per write(2) of zeros: a step of the
  // grower (appended and faulted in: about 20 µs of kernel work, during
  // which it holds its CPU), or the writer's own when it finds the grower
  // behind (about 17 µs per 64 KiB of records, where a write and a populate
  // per 4 KiB cost 6 µs every dozen records: the p99 of a burst).
  static constexpr size_t kGrowStep = 64 * 1024;
  static constexpr size_t kPrefault = 64 * 1024;  // pages faulted in per step
  static constexpr size_t kAhead = 256 * 1024;    // kept ready ahead of the writer
  mutable base::Mutex mu_ ACQUIRED_BEFORE(grow_mu_);
  char prev_[65] GUARDED_BY(mu_) = {};  // SHA-256 (hex) of the last line written, NUL-terminated
  std::string line_ GUARDED_BY(mu_);    // reused: the line being formatted
  enum class Mode { kNone, kStream, kFile };  // discard; write(2) only; a checked regular file
  Mode mode_ GUARDED_BY(mu_) = Mode::kNone;
  // fd_ and the window (map_, map_base_, map_len_) change with mu_ and
  // grow_mu_ held and are read with either: the analysis has no word for
  // that, so they carry no annotation.
  int fd_ = -1;  // kFile: -1 after the file was lost and could not be reopened
  bool owned_ GUARDED_BY(mu_) = false;
  std::string last_error_ GUARDED_BY(mu_);
  char* map_ = nullptr;  // the mapped window of a regular file, or null (write(2))
  off_t map_base_ = 0;   // file offset of map_[0]
  size_t map_len_ = 0;
  off_t pos_ GUARDED_BY(mu_) = 0;  // file offset of the next record (the end of the records)
  off_t checked_pos_ GUARDED_BY(mu_) = 0;  // pos_ at the last file check that found it whole
  uint64_t lines_ GUARDED_BY(mu_) = 0;
  uint64_t failures_ GUARDED_BY(mu_) = 0;
  uint64_t rotations_ GUARDED_BY(mu_) = 0;
  // Lines written to the current file other than `signal` events and its
  // `continues` record: a SIGHUP rotates only a file that recorded something.
  uint64_t recorded_in_file_ GUARDED_BY(mu_) = 0;
  std::string path_ GUARDED_BY(mu_);
  AuditOptions options_ GUARDED_BY(mu_);
  dev_t dev_ GUARDED_BY(mu_) = 0;
  ino_t ino_ GUARDED_BY(mu_) = 0;
  uint64_t next_check_us_ GUARDED_BY(mu_) = 0;          // monotonic: when the file is next checked
  uint64_t next_report_us_ GUARDED_BY(mu_) = 0;         // monotonic: stderr rate limit
  uint64_t unreported_ GUARDED_BY(mu_) = 0;             // failures not yet on stderr
  PerSecondLimit violation_limit_ GUARDED_BY(mu_){10};  // violations echoed or sent to the journal
  PerSecondLimit event_limit_ GUARDED_BY(mu_){20};      // events sent to the journal
  void journal_event_locked(const std::string& kind, const std::string& detail) REQUIRES(mu_);
  std::string cont_ GUARDED_BY(mu_);           // a continues or audit-gap record being formatted
  uint64_t gap_ GUARDED_BY(mu_) = 0;           // records lost since the last one written
  uint64_t gap_since_us_ GUARDED_BY(mu_) = 0;  // wall clock of the first of them
  std::string gap_why_ GUARDED_BY(mu_);        // the last reason
  // The grower: extends the file and faults its pages in ahead of the
  // writer. Lock order: mu_, then grow_mu_. The writer takes no lock but
  // mu_ below allocated_ (below ready_ without a page fault): it takes
  // grow_mu_ only to extend the file itself, so the grower, which holds it
  // while it appends zeros and gets the CPU last, rarely stalls it.
  base::Mutex grow_mu_;
  std::condition_variable grow_cv_;
  std::thread grower_;
  bool grow_stop_ GUARDED_BY(grow_mu_) = false;
  size_t file_room_ GUARDED_BY(grow_mu_) = 0;  // window bytes the file backs
  bool prefault_ GUARDED_BY(grow_mu_) = true;  // MADV_POPULATE_WRITE works
  std::vector<std::pair<char*, size_t>> retired_ GUARDED_BY(grow_mu_);  // old windows to unmap
  std::atomic<size_t> ready_{0};      // window bytes the writer may fill without a fault
  std::atomic<size_t> written_{0};    // window bytes filled so far
  std::atomic<size_t> allocated_{0};  // file_room_, for the writer and the file check
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
  std::string first_prev;          // the first line's "prev": where this file continues from
  std::string follows;             // a first `continues` record: the file it follows
};

struct AuditCheck {
  bool ok = true;
  uint64_t bad_line = 0;  // 1-based, when !ok
  std::string error;
  AuditSummary summary;  // of the lines up to the first bad one
};

// Verifies the chain line by line and summarises the log. With
// `continues_from` (the last hash of the file before, for rotated files),
// the first line must continue from it.
AuditCheck verify_audit(std::istream& in, const std::string& continues_from = {});

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_AUDIT_LOG_H_
