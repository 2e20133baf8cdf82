#include "monitor/audit_log.h"

#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fmt/format.h>
#include <iterator>
#include <nlohmann/json.hpp>  // the verifier only
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include "base/json_text.h"
#include "monitor/sha256.h"

namespace contego::monitor {
namespace {

uint64_t wall_us() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000u + static_cast<uint64_t>(ts.tv_nsec) / 1000u;
}

using Out = std::back_insert_iterator<std::string>;

void put_hex(std::string& out, const uint8_t* bytes, uint32_t len) {
  static const char* digits = "0123456789abcdef";
  for (uint32_t i = 0; bytes != nullptr && i < len; ++i) {
    if (i) out += ' ';
    out += digits[bytes[i] >> 4];
    out += digits[bytes[i] & 15];
  }
}

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
void put_string(std::string& out, std::string_view text) {
  out += '"';
  for (size_t i = 0; i < text.size();) {
    const char ch = text[i];
    const auto c = static_cast<unsigned char>(ch);
    if (c >= 0x80) {
      const size_t n = utf8_length(text, i);
      if (n == 0) {
        out += "\\ufffd";
        ++i;
      } else {
        out.append(text.substr(i, n));
        i += n;
      }
      continue;
    }
    ++i;
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20) {
          fmt::format_to(Out(out), "\\u{:04x}", c);
        } else {
          out += ch;
        }
    }
  }
  out += '"';
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

// Where the records of an existing log end: its size without the zero
// padding a killed monitor leaves after its last line (see AuditLog::open).
off_t data_end(int fd) {
  struct stat st {};
  if (fstat(fd, &st) != 0 || st.st_size <= 0) return 0;
  off_t end = st.st_size;
  char chunk[4096];
  while (end > 0) {
    const off_t start = end > static_cast<off_t>(sizeof chunk) ? end - sizeof chunk : 0;
    const auto len = static_cast<size_t>(end - start);
    if (pread(fd, chunk, len, start) != static_cast<ssize_t>(len)) return end;
    size_t i = len;
    while (i > 0 && chunk[i - 1] == 0) --i;
    if (i > 0) return start + static_cast<off_t>(i);
    end = start;
  }
  return 0;
}

// The end of the last complete line (after its newline) at or before `end`:
// a record cut off by a killed monitor is not continued from.
off_t complete_end(int fd, off_t end) {
  char chunk[4096];
  off_t pos = end;
  while (pos > 0) {
    const off_t start = pos > static_cast<off_t>(sizeof chunk) ? pos - sizeof chunk : 0;
    const auto len = static_cast<size_t>(pos - start);
    if (pread(fd, chunk, len, start) != static_cast<ssize_t>(len)) return end;
    for (size_t i = len; i > 0; --i) {
      if (chunk[i - 1] == '\n') return start + static_cast<off_t>(i);
    }
    pos = start;
  }
  return 0;
}

// The last non-empty line of an existing log whose records end at `size`,
// or "" (a new log).
std::string last_line(int fd, off_t size) {
  if (size <= 0) return {};
  const off_t start = size > 65536 ? size - 65536 : 0;
  std::string tail(static_cast<size_t>(size - start), '\0');
  if (pread(fd, tail.data(), tail.size(), start) != static_cast<ssize_t>(tail.size())) return {};
  while (!tail.empty() && tail.back() == '\n') tail.pop_back();
  const size_t nl = tail.rfind('\n');
  return nl == std::string::npos ? tail : tail.substr(nl + 1);
}

}  // namespace

AuditLog::~AuditLog() {
  if (grower_.joinable()) {
    {
      std::lock_guard g(grow_mu_);
      grow_stop_ = true;
    }
    grow_cv_.notify_one();
    grower_.join();
  }
  for (const auto& [addr, len] : retired_) munmap(addr, len);
  if (map_ != nullptr) {
    munmap(map_, map_len_);
    // A clean close removes the padding; a killed monitor leaves it, and
    // the next open() and the verifier skip it.
    (void)!ftruncate(fd_, pos_);
  }
  if (owned_ && fd_ >= 0) close(fd_);
}

// The file behind the window reaches at least `upto` bytes into it (in
// kMapChunk steps, zero-filled) and, while prefaulting works, the window's
// pages up to `upto` are faulted in writable. Publishes the result in
// ready_. grow_mu_ held.
bool AuditLog::extend_locked(size_t upto) {
  if (upto <= file_room_) return true;
  const size_t room = std::min(map_len_, (upto + kMapChunk - 1) / kMapChunk * kMapChunk);
  if (ftruncate(fd_, map_base_ + static_cast<off_t>(room)) != 0) return false;
  file_room_ = room;
  return true;
}

bool AuditLog::grow_locked(size_t upto) {
#ifndef MADV_POPULATE_WRITE
  constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14
#endif
  upto = std::min(upto, map_len_);
  if (!extend_locked(upto)) return false;
  if (!prefault_) {
    ready_.store(file_room_, std::memory_order_release);
    return true;
  }
  size_t populated = ready_.load(std::memory_order_relaxed);
  while (populated < upto) {
    const size_t len = std::min(kPrefault, file_room_ - populated);
    if (madvise(map_ + populated, len, MADV_POPULATE_WRITE) != 0) {
      prefault_ = false;  // an older kernel: records fault their pages in themselves
      ready_.store(file_room_, std::memory_order_release);
      return true;
    }
    populated += len;
    ready_.store(populated, std::memory_order_release);
  }
  return true;
}

// Maps a window of the file from the page holding `pos`, with room for
// `need` bytes. An old window is left to the grower to unmap (a munmap of
// many dirty pages is slow). mu_ and grow_mu_ held.
bool AuditLog::map_from_locked(off_t pos, size_t need) {
  if (map_ != nullptr) retired_.emplace_back(map_, map_len_);
  map_ = nullptr;
  ready_.store(0, std::memory_order_release);
  const long page = sysconf(_SC_PAGESIZE);
  const off_t base = pos - pos % page;
  const auto at = static_cast<size_t>(pos - base);
  const size_t len = std::max(kWindow, (at + need + kMapChunk) / kMapChunk * kMapChunk);
  // Address space only: what lies beyond the file's end is never touched.
  void* m = mmap(nullptr, len, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, base);
  if (m == MAP_FAILED) return false;
  map_ = static_cast<char*>(m);
  map_base_ = base;
  map_len_ = len;
  pos_ = pos;
  file_room_ = at;
  ready_.store(at / static_cast<size_t>(page) * static_cast<size_t>(page),
               std::memory_order_release);
  written_.store(at, std::memory_order_release);
  if (!grow_locked(at + need + kPrefault)) {
    munmap(map_, map_len_);
    map_ = nullptr;
    ready_.store(0, std::memory_order_release);
    (void)!ftruncate(fd_, pos);
    return false;
  }
  return true;
}

// The grower thread: keeps the file extended and its pages faulted in
// kAhead bytes ahead of the writer, off the path of the commands being
// recorded, and unmaps retired windows.
void AuditLog::grow_ahead() {
#ifndef MADV_POPULATE_WRITE
  constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14
#endif
  // Page work runs when nothing more important is ready: it must not
  // preempt the threads that check commands. (It never holds grow_mu_
  // while it works, so the writer never waits for it.)
  (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 19);
  std::unique_lock g(grow_mu_);
  while (!grow_stop_) {
    if (!retired_.empty()) {
      std::vector<std::pair<char*, size_t>> old;
      old.swap(retired_);
      g.unlock();
      for (const auto& [addr, len] : old) munmap(addr, len);
      g.lock();
      continue;
    }
    const size_t want = std::min(written_.load(std::memory_order_acquire) + kAhead, map_len_);
    const size_t from = ready_.load(std::memory_order_acquire);
    if (map_ == nullptr || from >= want) {
      // The writer notifies once it is within kAhead / 2 of ready_; the
      // timeout covers a notification sent just before this wait began.
      grow_cv_.wait_for(g, std::chrono::milliseconds(20));
      continue;
    }
    if (!extend_locked(want)) {
      grow_cv_.wait_for(g, std::chrono::milliseconds(20));
      continue;
    }
    if (!prefault_) {
      ready_.store(file_room_, std::memory_order_release);
      grow_cv_.wait_for(g, std::chrono::milliseconds(20));
      continue;
    }
    // Fault the next pages in without the lock: a window the writer
    // replaces meanwhile stays mapped until this thread unmaps it.
    char* const window = map_;
    const size_t len = std::min(kPrefault, file_room_ - from);
    if (len == 0) continue;
    g.unlock();
    const bool ok = madvise(window + from, len, MADV_POPULATE_WRITE) == 0;
    g.lock();
    if (window != map_) continue;
    if (!ok) {
      prefault_ = false;  // an older kernel: records fault their pages in themselves
      ready_.store(file_room_, std::memory_order_release);
      continue;
    }
    // The writer may have made room itself meanwhile: ready_ only grows.
    if (ready_.load(std::memory_order_relaxed) < from + len) {
      ready_.store(from + len, std::memory_order_release);
    }
  }
}

Status AuditLog::open(const std::string& path) {
  std::lock_guard lock(mu_);
  std::memcpy(prev_, kAuditGenesis, sizeof prev_);
  line_.reserve(1024);
  if (path == "-") {
    fd_ = STDERR_FILENO;
    owned_ = false;
    return {};
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_APPEND | O_CREAT | O_CLOEXEC, 0666);
  if (fd < 0) return make_error("cannot open audit log " + path + ": " + strerror(errno));
  off_t end = data_end(fd);
  end = complete_end(fd, end);
  // Zero padding and a record torn by a kill are cut off before continuing.
  if (ftruncate(fd, end) != 0) {
    // A file we may not shorten (append-only attribute): keep appending.
  }
  const std::string last = last_line(fd, end);
  if (!last.empty()) sha256_hex(last, prev_);
  fd_ = fd;
  owned_ = true;
  struct stat st {};
  // A regular file is extended ahead of the writer and mapped: a record is
  // a memcpy into the page cache (no system call), as durable against a
  // killed monitor as write(2) is. Anything else, or a failed mapping: write(2).
  if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) {
    std::lock_guard g(grow_mu_);
    if (map_from_locked(end, 0) && !grower_.joinable()) {
      grower_ = std::thread([this] { grow_ahead(); });
    }
  }
  return {};
}

void AuditLog::finish_line_locked() {
  line_ += ",\"prev\":\"";
  line_.append(prev_, 64);
  line_ += "\"}";
  sha256_hex(line_, prev_);
  line_ += '\n';
  if (map_ != nullptr) {
    size_t at = static_cast<size_t>(pos_ - map_base_);
    bool room = at + line_.size() <= ready_.load(std::memory_order_acquire);
    if (!room) {
      // The grower fell behind, or the window is full: make room here.
      std::lock_guard g(grow_mu_);
      room = at + line_.size() <= map_len_ ? grow_locked(at + line_.size() + kPrefault)
                                           : map_from_locked(pos_, line_.size());
      at = static_cast<size_t>(pos_ - map_base_);
    }
    if (room && map_ != nullptr) {
      std::memcpy(map_ + at, line_.data(), line_.size());
      pos_ += static_cast<off_t>(line_.size());
      const size_t written = at + line_.size();
      written_.store(written, std::memory_order_release);
      if (ready_.load(std::memory_order_relaxed) < written + kAhead / 2) {
        grow_cv_.notify_one();  // no system call unless the grower is waiting
      }
      return;
    }
    std::lock_guard g(grow_mu_);
    if (map_ != nullptr) retired_.emplace_back(map_, map_len_);
    map_ = nullptr;
    (void)!ftruncate(fd_, pos_);  // no mapping any more: continue with write(2)
  }
  // One write(2): in the page cache before the decision acts, so it
  // survives a killed monitor. O_APPEND keeps concurrent writers (another
  // monitor on the same file) from interleaving inside a line.
  size_t off = 0;
  while (off < line_.size()) {
    const ssize_t n = ::write(fd_, line_.data() + off, line_.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    off += static_cast<size_t>(n);
  }
}

// Keys sorted as the earlier JSON writer had them, except "prev", which
// comes last (it is appended when the rest of the line is known).
void AuditLog::decision(const core::AuditRecord& r, const char* task_name) {
  const uint64_t t = wall_us();
  std::lock_guard lock(mu_);
  ++lines_;
  if (fd_ < 0) return;
  line_.clear();
  fmt::format_to(Out(line_), "{{\"addr\":{},\"bus\":{},\"bytes\":\"", r.addr, r.bus);
  put_hex(line_, r.original, r.original_len);
  fmt::format_to(Out(line_), "\",\"command\":{},\"decision\":\"{}\",\"device\":{},\"fields\":[",
                 r.command, decision_str(r.decision), r.device);
  const uint8_t nfields = std::min<uint8_t>(r.field_count, 8);
  for (uint8_t i = 0; i < nfields; ++i) {
    fmt::format_to(Out(line_), "{}{}", i ? "," : "", r.fields[i]);
  }
  fmt::format_to(Out(line_),
                 "],\"index\":{},\"job\":{},\"kind\":\"decision\",\"reason\":{},\"rule\":{},"
                 "\"rule_kind\":{}",
                 r.index, r.job, static_cast<int>(r.reason), r.rule, static_cast<int>(r.rule_kind));
  if (r.substitute != nullptr) {
    line_ += ",\"substitute\":\"";
    put_hex(line_, r.substitute, r.substitute_len);
    line_ += '"';
  }
  fmt::format_to(Out(line_), ",\"t_us\":{},\"task\":{}", t, r.task);
  if (task_name != nullptr) {
    line_ += ",\"task_name\":";
    put_string(line_, task_name);
  }
  finish_line_locked();
}

void AuditLog::event(const std::string& kind, const std::string& detail) {
  const uint64_t t = wall_us();
  std::lock_guard lock(mu_);
  ++lines_;
  if (fd_ < 0) return;
  line_.clear();
  line_ += "{\"detail\":";
  put_string(line_, detail);
  line_ += ",\"kind\":";
  put_string(line_, kind);
  fmt::format_to(Out(line_), ",\"t_us\":{}", t);
  finish_line_locked();
}

uint64_t AuditLog::lines() const {
  std::lock_guard lock(mu_);
  return lines_;
}

namespace {

// A record cut off by a kill is the start of a record: it opens an object,
// and if it got as far as its "prev", that names the hash of the line before
// (`prev_hash`; empty: any, for the first line of a file).
bool is_torn_record(std::string_view tail, std::string_view prev_hash) {
  if (tail != "{" && !tail.starts_with("{\"")) return false;
  static constexpr std::string_view kPrev = "\"prev\":\"";
  const size_t at = tail.find(kPrev);
  if (at == std::string_view::npos) return true;
  const std::string_view hash = tail.substr(at + kPrev.size(), 64);
  if (prev_hash.empty()) {
    return hash.find_first_not_of("0123456789abcdef") == std::string_view::npos;
  }
  return prev_hash.starts_with(hash);
}

}  // namespace

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
    // The writer never writes an empty line: one here was inserted.
    if (line.empty() && !in.eof()) return fail("blank line (inserted: the monitor writes none)");
    if (line.empty()) break;
    // getline stopped at the end of the file, not at a newline: the tail of
    // a mapped log whose monitor was killed. Zero padding is skipped; a
    // record cut off by the kill (its decision never acted: a record is
    // complete before its decision acts) is reported, not refused.
    const bool unterminated = in.eof();
    if (unterminated) {
      const size_t last = line.find_last_not_of('\0');
      if (last == std::string::npos) break;  // only padding
      line.resize(last + 1);
    }
    if (line.find('\0') != std::string::npos) return fail("zero bytes inside the log");
    if (unterminated &&
        (line.back() != '}' || nlohmann::json::parse(line, nullptr, false).is_discarded())) {
      if (!is_torn_record(line, s.lines == 0 ? std::string_view{} : prev_hash)) {
        return fail("text after the last record that is no record cut off by a kill");
      }
      s.torn_tail = true;
      break;
    }
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
