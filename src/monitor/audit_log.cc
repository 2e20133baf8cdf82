#include "monitor/audit_log.h"

#include <fcntl.h>
#include <setjmp.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include <mutex>
#include <nlohmann/json.hpp>  // the verifier only
#include <sstream>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <sys/sysmacros.h>

#include "contego/core/checker.h"

#include "base/clock.h"
#include "base/json_text.h"
#include "monitor/audit_internal.h"
#include "monitor/sha256.h"

namespace contego::monitor {

using audit_detail::guarded_copy;

namespace {

uint64_t wall_us() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
}

using Out = std::back_insert_iterator<std::string>;

// Appends to a string through a raw pointer: the decision line is written
// on the path of every checked command, and std::string's append per piece
// or fmt's format strings cost more than the line's SHA-256
// (bench/monitor_bench). Every put makes room for what it writes; done()
// trims the string to what was written.
class LineWriter {
 public:
  explicit LineWriter(std::string& out) : out_(out) {
    const size_t used = out.size();
    out_.resize(std::max(out_.capacity(), used + 512));
    p_ = out_.data() + used;
    end_ = out_.data() + out_.size();
  }
  LineWriter(const LineWriter&) = delete;
  LineWriter& operator=(const LineWriter&) = delete;
  ~LineWriter() { done(); }
  __attribute__((always_inline)) void room(size_t n) {
    if (static_cast<size_t>(end_ - p_) >= n) [[likely]]
      return;
    grow(n);
  }
  void grow(size_t n) {
    const size_t used = static_cast<size_t>(p_ - out_.data());
    out_.resize(used + n + 512);
    p_ = out_.data() + used;
    end_ = out_.data() + out_.size();
  }
  void done() { out_.resize(static_cast<size_t>(p_ - out_.data())); }

  template <size_t N>
  void put(const char (&text)[N]) {
    room(N - 1);
    std::memcpy(p_, text, N - 1);
    p_ += N - 1;
  }
  void put(std::string_view text) {
    room(text.size());
    std::memcpy(p_, text.data(), text.size());
    p_ += text.size();
  }
  void put(char c) {
    room(1);
    *p_++ = c;
  }
  template <typename T>
  void number(T value) {
    room(24);
    p_ = std::to_chars(p_, p_ + 24, value).ptr;
  }
  template <size_t N, typename T>
  void number(const char (&key)[N], T value) {  // `key` is the text before the number
    put(key);
    number(value);
  }
  void hex(const uint8_t* bytes, uint32_t len) {
    static const char* digits = "0123456789abcdef";
    if (bytes == nullptr || len == 0) return;
    room(3 * size_t{len});
    for (uint32_t i = 0; i < len; ++i) {
      if (i) *p_++ = ' ';
      *p_++ = digits[bytes[i] >> 4];
      *p_++ = digits[bytes[i] & 15];
    }
  }
  void string(std::string_view text);

 private:
  std::string& out_;
  char* p_ = nullptr;
  char* end_ = nullptr;
};

// Length of the valid UTF-8 sequence at text[i], or 0 if it is not one.
size_t utf8_length(std::string_view text, size_t i) {
  const auto c = static_cast<unsigned char>(text[i]);
  size_t n = 0;
  uint32_t cp = 0;
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
    cp = c & 0x1Fu;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    cp = c & 0x0Fu;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    cp = c & 0x07u;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    const auto cc = static_cast<unsigned char>(text[i + k]);
    if ((cc & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (cc & 0x3Fu);
  }
  const bool overlong = (n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000);
  if (overlong || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
  return n;
}

// A JSON string literal. Invalid UTF-8 (a client's task name, say) becomes
// U+FFFD: a hostile string costs a replacement character, never a line the
// verifier cannot read.
void LineWriter::string(std::string_view text) {
  room(2 + 6 * text.size());  // no character takes more than \u00XX
  *p_++ = '"';
  for (size_t i = 0; i < text.size();) {
    const char ch = text[i];
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x80) {
      const size_t n = utf8_length(text, i);
      if (n == 0) {
        std::memcpy(p_, "\\ufffd", 6);
        p_ += 6;
        ++i;
      } else {
        std::memcpy(p_, text.data() + i, n);
        p_ += n;
        i += n;
      }
      continue;
    }
    ++i;
    if (c >= 0x20 && c != '"' && c != '\\') {
      *p_++ = ch;
      continue;
    }
    *p_++ = '\\';
    switch (c) {
      case '"':
      case '\\':
        *p_++ = ch;
        break;
      case '\n':
        *p_++ = 'n';
        break;
      case '\r':
        *p_++ = 'r';
        break;
      case '\t':
        *p_++ = 't';
        break;
      default:
        static const char* digits = "0123456789abcdef";
        std::memcpy(p_, "u00", 3);
        p_[3] = digits[c >> 4];
        p_[4] = digits[c & 15];
        p_ += 5;
    }
  }
  *p_++ = '"';
}

void put_string(std::string& out, std::string_view text) {
  LineWriter w(out);
  w.string(text);
}

}  // namespace

bool AuditLog::start_continuation_locked(const std::string& follows, const char* old_hash,
                                         const std::string& why) {
  recorded_in_file_ = 0;  // a new file: its continues record is not a record of its own
  cont_.clear();
  cont_ += "{\"continues\":\"";
  cont_.append(old_hash, 64);
  cont_ += "\",\"detail\":";
  put_string(cont_, why);
  cont_ += ",\"follows\":";
  put_string(cont_, follows);
  fmt::format_to(Out(cont_), ",\"kind\":\"continues\",\"t_us\":{}", wall_us());
  return commit_locked(cont_, true);
}

bool AuditLog::rotate_locked(const std::string& why) {
  if (mode_ != Mode::kFile || fd_ < 0) return false;
  // Renamed while still locked and open: no other writer can slip in. Only
  // the files that are there move (PATH.1 .. PATH.n, then the first gap):
  // a rotation costs the kept files, not --audit-keep renames (a keep of
  // 100,000 made every rotation 0.4 s of failed renames under the lock).
  unsigned present = 1;
  struct stat st {};
  while (present < options_.keep &&
         ::stat(fmt::format("{}.{}", path_, present).c_str(), &st) == 0) {
    ++present;
  }
  for (unsigned k = present; k > 1; --k) {
    const std::string from = fmt::format("{}.{}", path_, k - 1);
    (void)std::rename(from.c_str(), fmt::format("{}.{}", path_, k).c_str());
  }
  const std::string rotated = path_ + ".1";
  if (std::rename(path_.c_str(), rotated.c_str()) != 0) {
    last_error_ = "cannot rotate " + path_ + ": " + strerror(errno);
    return false;
  }
  char old[65];
  std::memcpy(old, prev_, sizeof old);
  close_file_locked();
  if (Status s = open_file_locked(); !s.ok()) {
    last_error_ = s.error();
    return false;
  }
  ++rotations_;
  return start_continuation_locked(rotated, old, why);
}

Result<std::string> AuditLog::reopen() {
  base::MutexLock lock(mu_);
  if (mode_ != Mode::kFile) return std::string("the audit log is not a file: nothing to reopen");
  struct stat named {};
  const bool still_named =
      fd_ >= 0 && stat(path_.c_str(), &named) == 0 && named.st_dev == dev_ && named.st_ino == ino_;
  if (options_.max_bytes > 0 && still_named && pos_ > 0 && recorded_in_file_ == 0) {
    // A burst of SIGHUPs must not push the kept files out with empty ones.
    return fmt::format("{} recorded nothing since it began: kept, not rotated", path_);
  }
  if (options_.max_bytes > 0 && still_named && pos_ > 0) {
    if (!rotate_locked("SIGHUP")) return make_error(last_error_);
    return fmt::format("rotated: {} -> {}.1; a new {} continues the chain", path_, path_, path_);
  }
  const uint64_t before = rotations_ + failures_;
  const int fd_before = fd_;
  const ino_t ino_before = ino_;
  check_file_locked(true);
  if (fd_ < 0) return make_error("cannot reopen " + path_ + ": " + last_error_);
  if (fd_ != fd_before || ino_ != ino_before || before != rotations_ + failures_) {
    ++rotations_;
    return fmt::format("reopened {}: a new file continues the chain", path_);
  }
  return fmt::format("{} is still the open file: kept", path_);
}

void AuditLog::report_failure_locked(const std::string& why) {
  ++unreported_;
  const uint64_t now = monotonic_us();
  if (now < next_report_us_) return;
  next_report_us_ = now + 1000000;
  std::string message = fmt::format(
      "contego: AUDIT LOG FAILURE: {}: {}; what it records does not act ({} record(s) "
      "not written since the last message)",
      path_, why, unreported_);
  unreported_ = 0;
  if (options_.journal) {
    JournalEntry e;
    e.priority = Priority::kError;
    e.kind = "audit-failure";
    e.message = std::move(message);
    options_.journal(e);
  } else {
    fmt::print(stderr, "{}\n", message);
  }
}

// write(2) without SIGPIPE: a stream whose reader left answers EPIPE, a
// failure the log reports (and the monitor then refuses what it records),
// instead of a signal that would end the monitor. SIGPIPE is blocked in this
// thread for the call and a pending one taken back.
static ssize_t write_no_sigpipe(int fd, const char* data, size_t size) {
  sigset_t pipe_only, old;
  sigemptyset(&pipe_only);
  sigaddset(&pipe_only, SIGPIPE);
  sigset_t pending;
  sigpending(&pending);
  const bool was_pending = sigismember(&pending, SIGPIPE) == 1;
  pthread_sigmask(SIG_BLOCK, &pipe_only, &old);
  const ssize_t n = ::write(fd, data, size);
  const int saved = errno;
  if (n < 0 && saved == EPIPE && !was_pending) {
    const timespec zero{0, 0};
    while (sigtimedwait(&pipe_only, nullptr, &zero) < 0 && errno == EINTR) {
    }
  }
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
  errno = saved;
  return n;
}

bool AuditLog::write_fd_locked(const std::string& line) {
  size_t off = 0;
  while (off < line.size()) {
    const ssize_t n = mode_ == Mode::kStream
                          ? write_no_sigpipe(fd_, line.data() + off, line.size() - off)
                          : ::write(fd_, line.data() + off, line.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      last_error_ = n < 0 ? strerror(errno) : "short write";
      // Half a line in a regular file would break the chain: take it back.
      if (mode_ == Mode::kFile && off > 0) (void)!ftruncate(fd_, pos_);
      return false;
    }
    off += static_cast<size_t>(n);
  }
  pos_ += static_cast<off_t>(line.size());
  return true;
}

bool AuditLog::put_locked(const std::string& line) {
  if (fd_ < 0) {
    if (last_error_.empty()) last_error_ = "no log file open";
    return false;
  }
  if (map_ == nullptr) return write_fd_locked(line);
  size_t at = static_cast<size_t>(pos_ - map_base_);
  // Below ready_ the pages are faulted in; below allocated_ the copy
  // faults its own (a few µs), still without the grower's lock.
  bool room = at + line.size() <= ready_.load(std::memory_order_acquire) ||
              at + line.size() <= allocated_.load(std::memory_order_acquire);
  if (!room) {
    // The grower fell behind on allocating (a burst of records on busy
    // CPUs), the window is full, or the file system is: make room here.
    // Zeros appended kGrowStep at once, in one write(2), and no page
    // populated: the copy faults its page in itself, and one fault maps the
    // whole folio the append made (Linux 6.x page cache), so a burst pays
    // one system call per 64 KiB of records, not one per page.
    base::MutexLock g(grow_mu_);
    if (at + line.size() <= map_len_) {
      (void)extend_locked(at + line.size() + kGrowStep);
      room = at + line.size() <= allocated_.load(std::memory_order_relaxed);
    } else {
      room = map_from_locked(pos_, line.size());
    }
    at = static_cast<size_t>(pos_ - map_base_);
  }
  if (!room || map_ == nullptr) {
    last_error_ = "no space left to allocate for the record";
    return false;
  }
  if (!guarded_copy(map_ + at, line.data(), line.size())) {
    last_error_ = "the log file was cut under the record (SIGBUS caught)";
    return false;
  }
  pos_ += static_cast<off_t>(line.size());
  const size_t written = at + line.size();
  written_.store(written, std::memory_order_release);
  if (ready_.load(std::memory_order_relaxed) < written + kAhead / 2) {
    grow_cv_.notify_one();  // no system call unless the grower is waiting
  }
  return true;
}

bool AuditLog::commit_locked(std::string& body, bool continuation) {
  if (mode_ == Mode::kNone) {
    ++lines_;
    return true;
  }
  if (!continuation) {
    check_file_locked(false);
    if (gap_ > 0) {
      // The first line after records were lost says so: the log shows the
      // gap (none of the lost records' actions happened).
      cont_.clear();
      cont_ += "{\"detail\":";
      put_string(cont_, fmt::format("{} record(s) could not be written since t_us {} ({}); "
                                    "the actions they would have recorded did not happen",
                                    gap_, gap_since_us_, gap_why_));
      fmt::format_to(Out(cont_), ",\"kind\":\"audit-gap\",\"t_us\":{}", wall_us());
      if (commit_locked(cont_, true)) gap_ = 0;
    }
    if (mode_ == Mode::kFile && options_.max_bytes > 0 && fd_ >= 0 && pos_ > 0 &&
        static_cast<uint64_t>(pos_) + body.size() + 80 > options_.max_bytes) {
      (void)rotate_locked(fmt::format("size limit of {} bytes", options_.max_bytes));
    }
  }
  const size_t body_len = body.size();
  for (int attempt = 0;; ++attempt) {
    body.resize(body_len);
    body += ",\"prev\":\"";
    body.append(prev_, 64);
    body += "\"}";
    char next[65];
    sha256_hex(body, next);
    body += '\n';
    if (put_locked(body)) {
      std::memcpy(prev_, next, sizeof prev_);
      ++lines_;
      return true;
    }
    if (attempt > 0 || continuation || mode_ != Mode::kFile) break;
    // A truncation or deletion under the record: continue in the right
    // place (after a `continues` record) and try once more.
    check_file_locked(true);
    if (fd_ < 0) break;
  }
  if (!continuation) {
    ++failures_;  // a record its caller is told was not written
    if (gap_++ == 0) gap_since_us_ = wall_us();
    gap_why_ = last_error_;
  }
  report_failure_locked(last_error_);
  return false;
}

// Keys sorted as the earlier JSON writer had them, except "prev", which
// comes last (it is appended when the rest of the line is known).
bool AuditLog::decision(const core::AuditRecord& r, const RecordNames& names) {
  const uint64_t t = names.t_us >= 0 ? static_cast<uint64_t>(names.t_us) : wall_us();
  base::MutexLock lock(mu_);
  if (mode_ == Mode::kNone) {
    ++lines_;
    return true;
  }
  // Each name beside its number, so a person reads the line without the image.
  line_.clear();
  LineWriter w(line_);
  auto name = [&w](std::string_view key, const char* value) {
    if (value == nullptr) return;
    w.put(",\"");
    w.put(key);
    w.put("\":");
    w.string(value);
  };
  w.number("{\"addr\":", r.addr);
  w.number(",\"bus\":", r.bus);
  w.put(",\"bytes\":\"");
  w.hex(r.original, r.original_len);
  w.number("\",\"command\":", r.command);
  name("command_name", names.command);
  if (names.complain) w.put(",\"complain\":true");
  w.put(",\"decision\":\"");
  w.put(std::string_view(core::decision_name(r.decision)));
  w.number("\",\"device\":", r.device);
  name("device_name", names.device);
  w.put(",\"fields\":[");
  const uint8_t nfields = std::min<uint8_t>(r.field_count, 8);
  for (uint8_t i = 0; i < nfields; ++i) {
    if (i) w.put(',');
    w.number(r.fields[i]);
  }
  w.number("],\"index\":", r.index);
  w.number(",\"job\":", r.job);
  w.put(",\"kind\":\"decision\"");
  if (names.mono_us >= 0) w.number(",\"mono_us\":", names.mono_us);
  if (names.pid >= 0) w.number(",\"pid\":", names.pid);
  if (names.readings != nullptr && !names.readings->empty()) {
    w.put(",\"readings\":");
    w.put(*names.readings);
  }
  w.number(",\"reason\":", static_cast<int>(r.reason));
  w.put(",\"reason_name\":\"");
  w.put(std::string_view(core::reason_name(r.reason)));
  w.number("\",\"rule\":", r.rule);
  w.number(",\"rule_kind\":", static_cast<int>(r.rule_kind));
  name("rule_name", names.rule);
  if (r.substitute != nullptr) {
    w.put(",\"substitute\":\"");
    w.hex(r.substitute, r.substitute_len);
    w.put('"');
  }
  w.number(",\"t_us\":", t);
  w.number(",\"task\":", r.task);
  name("task_name", names.task);
  if (names.tx >= 0) w.number(",\"tx\":", names.tx);
  if (names.uid >= 0) w.number(",\"uid\":", names.uid);
  w.done();
  const bool written = commit_locked(line_);
  if (written) ++recorded_in_file_;
  if ((options_.echo_violations || options_.journal) && r.decision != core::Decision::kAllow)
    echo_violation_locked(r, names);
  return written;
}

void AuditLog::echo_violation_locked(const core::AuditRecord& r, const RecordNames& names) {
  if (!violation_limit_.admit(monotonic_us())) return;
  auto or_number = [](const char* name, unsigned number) {
    return name != nullptr ? std::string(name) : std::to_string(number);
  };
  std::string left_out;
  if (const uint64_t n = violation_limit_.take_left_out(); n > 0) {
    left_out = fmt::format(" ({} more left out before this one)", n);
  }
  JournalEntry e;
  e.task = or_number(names.task, r.task);
  e.verdict = core::decision_name(r.decision);
  e.command = or_number(names.command, r.command);
  e.device = or_number(names.device, r.device);
  e.reason = core::reason_name(r.reason);
  e.rule = or_number(names.rule, r.rule);
  e.message = fmt::format("contego: task {}: {} of command {} on device {} ({}, rule {}){}", e.task,
                          e.verdict, e.command, e.device, e.reason, e.rule, left_out);
  if (!options_.journal) {
    fmt::print(stderr, "{}\n", e.message);
    return;
  }
  // A latch or a substituted command is a warning; a command dropped, a notice.
  const bool latch = e.rule == "latch";
  e.kind = latch ? "latch" : "decision";
  e.priority =
      latch || r.decision == core::Decision::kFailsafe ? Priority::kWarning : Priority::kNotice;
  options_.journal(e);
}

void AuditLog::set_journal(JournalSink journal) {
  base::MutexLock lock(mu_);
  options_.journal = std::move(journal);
}

void AuditLog::journal_event_locked(const std::string& kind, const std::string& detail) {
  if (!event_limit_.admit(monotonic_us())) return;
  JournalEntry e;
  e.kind = kind;
  e.priority = event_priority(kind);
  e.message = fmt::format("contego: {}: {}", kind, detail);
  if (const uint64_t n = event_limit_.take_left_out(); n > 0) {
    e.message += fmt::format(" ({} more events left out before this one)", n);
  }
  options_.journal(e);
}

bool AuditLog::event(const std::string& kind, const std::string& detail) {
  return event(kind, detail, -1, -1);
}

bool AuditLog::event(const std::string& kind, const std::string& detail, int64_t t_us,
                     int64_t mono_us) {
  const uint64_t t = t_us >= 0 ? static_cast<uint64_t>(t_us) : wall_us();
  base::MutexLock lock(mu_);
  if (mode_ == Mode::kNone) {
    ++lines_;
    return true;
  }
  line_.clear();
  line_ += "{\"detail\":";
  put_string(line_, detail);
  line_ += ",\"kind\":";
  put_string(line_, kind);
  if (mono_us >= 0) fmt::format_to(Out(line_), ",\"mono_us\":{}", mono_us);
  fmt::format_to(Out(line_), ",\"t_us\":{}", t);
  const bool written = commit_locked(line_);
  if (written && kind != "signal") ++recorded_in_file_;
  if (options_.journal) journal_event_locked(kind, detail);
  return written;
}

bool AuditLog::anchored_event(
    const std::string& kind,
    const std::function<std::string(const std::string& prev_hash, uint64_t records)>& detail) {
  const uint64_t t = wall_us();
  base::MutexLock lock(mu_);
  if (mode_ == Mode::kNone) return false;
  const std::string text = detail(prev_, lines_);
  if (text.empty()) return false;
  line_.clear();
  line_ += "{\"detail\":";
  put_string(line_, text);
  line_ += ",\"kind\":";
  put_string(line_, kind);
  fmt::format_to(Out(line_), ",\"t_us\":{}", t);
  const bool written = commit_locked(line_);
  if (written) ++recorded_in_file_;
  if (options_.journal) journal_event_locked(kind, text);
  return written;
}

uint64_t AuditLog::failures() const {
  base::MutexLock lock(mu_);
  return failures_;
}

uint64_t AuditLog::rotations() const {
  base::MutexLock lock(mu_);
  return rotations_;
}

std::string AuditLog::path() const {
  base::MutexLock lock(mu_);
  return path_;
}

std::string AuditLog::last_hash() const {
  base::MutexLock lock(mu_);
  return prev_;
}

uint64_t AuditLog::position() const {
  base::MutexLock lock(mu_);
  return static_cast<uint64_t>(pos_);
}

uint64_t AuditLog::lines() const {
  base::MutexLock lock(mu_);
  return lines_;
}
}  // namespace contego::monitor
