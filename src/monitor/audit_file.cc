// The audit log's file: opening and checking it, the shared mapping it is
// written through, and the helper thread that grows it ahead of the writer.
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
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
#include "base/read_file.h"
#include "base/unique_fd.h"
#include "monitor/audit_internal.h"
#include "monitor/audit_log.h"
#include "monitor/sha256.h"

namespace contego::monitor {

using audit_detail::kCheckEveryUs;

namespace {

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

// The path the kernel has for an open file ("... (deleted)" once unlinked).
std::string fd_path(int fd) {
  char buf[4096];
  const std::string link = "/proc/self/fd/" + std::to_string(fd);
  const ssize_t n = readlink(link.c_str(), buf, sizeof buf - 1);
  return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string("?");
}

// Who holds the flock of the file `st` describes, from /proc/locks: "pid N
// (comm)", or "" if it cannot be told.
std::string lock_holder(const struct stat& st) {
  const std::string want = fmt::format("{:02x}:{:02x}:{}", major(st.st_dev), minor(st.st_dev),
                                       static_cast<unsigned long>(st.st_ino));
  std::ifstream in("/proc/locks");
  for (std::string line; std::getline(in, line);) {
    if (line.find("->") != std::string::npos || line.find("FLOCK") == std::string::npos) continue;
    std::istringstream words(line);
    std::string id, type, advisory, mode, pid, dev;
    if (!(words >> id >> type >> advisory >> mode >> pid >> dev) || dev != want) continue;
    std::ifstream comm("/proc/" + pid + "/comm");
    std::string name;
    std::getline(comm, name);
    return name.empty() ? "pid " + pid : "pid " + pid + " (" + name + ")";
  }
  return {};
}

// The SIGBUS guard of the copy into the mapped log. Space is allocated
// ahead of the writer, so a page of the window faults only if another
// process cut the file under the mapping (logrotate's copytruncate, a
// truncate(1)) between the writer's checks and its copy: the copy is then
// abandoned, the record counts as not written, and the writer resyncs with
// the file and retries. A SIGBUS anywhere else goes to the previous handler
// (the default: the process dies, as it would have).
thread_local sigjmp_buf* t_jump = nullptr;
thread_local const char* t_lo = nullptr;
thread_local const char* t_hi = nullptr;
struct sigaction g_previous_bus {};

void on_sigbus(int sig, siginfo_t* info, void* context) {
  const auto* at = static_cast<const char*>(info->si_addr);
  if (t_jump != nullptr && at >= t_lo && at < t_hi) siglongjmp(*t_jump, 1);
  if ((g_previous_bus.sa_flags & SA_SIGINFO) != 0 && g_previous_bus.sa_sigaction != nullptr) {
    g_previous_bus.sa_sigaction(sig, info, context);
    return;
  }
  if (g_previous_bus.sa_handler == SIG_DFL || g_previous_bus.sa_handler == SIG_IGN) {
    (void)signal(SIGBUS, SIG_DFL);  // the faulting access repeats and ends the process
    return;
  }
  g_previous_bus.sa_handler(sig);
}

void install_sigbus_guard() {
  static std::once_flag once;
  std::call_once(once, [] {
    struct sigaction sa {};
    sa.sa_sigaction = &on_sigbus;
    sa.sa_flags = SA_SIGINFO | SA_NODEFER;  // no mask to restore: no system call per copy
    sigemptyset(&sa.sa_mask);
    sigaction(SIGBUS, &sa, &g_previous_bus);
  });
}

constexpr off_t kStartRoom = 64 * 1024;  // the space open() insists on

}  // namespace

namespace audit_detail {

bool guarded_copy(char* dst, const char* src, size_t n) {
  sigjmp_buf jump;
  if (sigsetjmp(jump, 0) != 0) {
    t_jump = nullptr;
    return false;
  }
  t_lo = dst;
  t_hi = dst + n;
  std::atomic_signal_fence(std::memory_order_seq_cst);
  t_jump = &jump;
  std::atomic_signal_fence(std::memory_order_seq_cst);
  std::memcpy(dst, src, n);
  std::atomic_signal_fence(std::memory_order_seq_cst);
  t_jump = nullptr;
  return true;
}

}  // namespace audit_detail

AuditLog::~AuditLog() {
  if (grower_.joinable()) {
    {
      base::MutexLock g(grow_mu_);
      grow_stop_ = true;
    }
    grow_cv_.notify_one();
    grower_.join();
  }
  base::MutexLock lock(mu_);
  close_file_locked();
  for (const auto& [addr, len] : retired_) munmap(addr, len);
  retired_.clear();
}

// The file behind the window reaches at least `upto` bytes into it (at
// most the window's end), its blocks allocated, so that a full file system
// fails here and not as a SIGBUS on a page of the window: zeros appended
// (the descriptor is O_APPEND) kGrowStep at a time, as far as they fit.
// Written zeros, not posix_fallocate: ext4 keeps a fallocated range as an
// unwritten extent and converts it at the first store into it, and tmpfs
// zeroes its pages in the fallocate itself, both about 0.3 µs per KiB of
// the range in one stretch of kernel work (350 µs for a MiB) that held the
// CPU of whichever thread did it, while a request waited behind it.
// grow_mu_ held.
bool AuditLog::extend_locked(size_t upto) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  upto = std::min(map_len_, (upto + page - 1) / page * page);
  if (upto <= file_room_) return true;
  if (fd_ < 0) return false;
  struct stat st {};
  if (fstat(fd_, &st) != 0) return false;
  off_t end = st.st_size;  // where the next append lands
  // Shorter than what was allocated: cut under the writer (copytruncate).
  // Appending here would hide the cut behind zeros the writer then fills
  // without noticing; left short, its next record faults (SIGBUS caught)
  // and continues the chain in the cut file at once.
  if (end < map_base_ + static_cast<off_t>(file_room_)) return false;
  const off_t want = map_base_ + static_cast<off_t>(upto);
  static const char kZeros[kGrowStep] = {};
  while (end < want) {
    const auto n = static_cast<size_t>(std::min<off_t>(static_cast<off_t>(kGrowStep), want - end));
    const ssize_t w = ::write(fd_, kZeros, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) break;  // ENOSPC, EDQUOT, EFBIG, EIO: what was written stays usable
    end += w;
  }
  if (end > map_base_) {
    const size_t room = std::min(map_len_, static_cast<size_t>(end - map_base_));
    if (room > file_room_) {
      file_room_ = room;
      allocated_.store(room, std::memory_order_release);
    }
  }
  return file_room_ >= upto;
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
      if (errno == EFAULT) return false;  // the file was cut under the window
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
  allocated_.store(at, std::memory_order_release);
  prefault_ = true;
  ready_.store(at / static_cast<size_t>(page) * static_cast<size_t>(page),
               std::memory_order_release);
  written_.store(at, std::memory_order_release);
  if (!grow_locked(at + need + kPrefault) && !grow_locked(at + need)) {
    retired_.emplace_back(map_, map_len_);
    map_ = nullptr;
    ready_.store(0, std::memory_order_release);
    return false;
  }
  return true;
}

// The grower thread: keeps the file's blocks allocated and its pages faulted
// in kAhead bytes ahead of the writer, off the path of the commands being
// recorded, and unmaps retired windows.
void AuditLog::grow_ahead() {
#ifndef MADV_POPULATE_WRITE
  constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14
#endif
  // Page work runs when nothing more important is ready: it must not
  // delay the threads that check commands. SCHED_BATCH: a woken batch
  // thread never preempts the one that woke it (under EEVDF, Linux 6.6 on,
  // a woken nice-19 thread does); nice 19: the least share of a busy CPU
  // that still keeps up with a busy writer (SCHED_IDLE's would not). (It
  // never holds grow_mu_ while it faults pages in, so the writer never
  // waits for it.)
  const sched_param batch{};
  (void)sched_setscheduler(0, SCHED_BATCH, &batch);  // this thread only
  (void)setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 19);
  (void)pthread_setname_np(pthread_self(), kGrowerThreadName);  // for top -H, ps -L and the tests
  const size_t step = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  base::MutexLock g(grow_mu_);
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
    // Pages the writer has filled meanwhile (faulting them in itself when
    // this thread was behind) need nothing more.
    const size_t from = std::max(ready_.load(std::memory_order_acquire),
                                 written_.load(std::memory_order_acquire) / step * step);
    if (map_ == nullptr || from >= want) {
      // Nothing to do until the writer comes within kAhead / 2 of ready_:
      // it then notifies after every record until this thread has caught
      // up, so a notification lost just before this wait is followed by
      // another with the next record, and an idle log wakes no one.
      g.wait(grow_cv_);
      continue;
    }
    // One step of the file at a time, like the pages below: the kernel
    // work of an extension grows with its length.
    if (!extend_locked(std::min(want, file_room_ + kGrowStep)) && file_room_ <= from) {
      // No space: the writer sees it when it reaches the end of what is
      // allocated (its record fails, the action is refused); this thread
      // tries again at the writer's next notification.
      g.wait(grow_cv_);
      continue;
    }
    if (!prefault_) {
      ready_.store(file_room_, std::memory_order_release);
      g.wait(grow_cv_);
      continue;
    }
    // Fault the next pages in without the lock: a window the writer
    // replaces meanwhile stays mapped until this thread unmaps it.
    // One step at a time, the CPU given back after each: a thread that
    // yields to this one (the channel's spinning server does, every few
    // hundred ns) waits for one step. 64 KiB of appended zeros, one large
    // folio, take about 20 µs with their populate; one step per page cost
    // c2 ~10 µs on every page of records (its p99), and 64 KiB of a
    // posix_fallocate'd range cost ~100 µs (round 9).
    char* const window = map_;
    const size_t len = std::min(kGrowStep, file_room_ - from);
    if (len == 0) continue;
    g.unlock();
    const bool ok = madvise(window + from, len, MADV_POPULATE_WRITE) == 0;
    const int err = errno;
    sched_yield();
    g.lock();
    if (window != map_) continue;
    if (!ok) {
      if (err == EFAULT) {
        // The file was cut under the window: the writer's check resyncs.
        g.wait(grow_cv_);
        continue;
      }
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

Status AuditLog::open(const std::string& path, const AuditOptions& options) {
  base::MutexLock lock(mu_);
  close_file_locked();
  std::memcpy(prev_, kAuditGenesis, sizeof prev_);
  line_.reserve(1024);
  options_ = options;
  if (options_.keep == 0) options_.keep = 1;
  path_ = path;
  if (path == "-") {
    mode_ = Mode::kStream;
    fd_ = STDERR_FILENO;
    owned_ = false;
    return {};
  }
  mode_ = Mode::kFile;
  Status s = open_file_locked();
  if (!s.ok()) mode_ = Mode::kNone;
  return s;
}

Status AuditLog::open_file_locked() {
  // Closed on every refusal below; fd_ takes it over once the log is open.
  base::UniqueFd owned(
      ::open(path_.c_str(), O_RDWR | O_APPEND | O_CREAT | O_CLOEXEC | O_NOCTTY | O_NONBLOCK, 0666));
  const int fd = owned.get();
  if (fd < 0) return make_error("cannot open audit log " + path_ + ": " + strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    return make_error("cannot stat audit log " + path_ + ": " + strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    if (!options_.allow_unsafe) {
      return make_error(fmt::format(
          "audit log {} is {}, not a regular file: what is written there cannot be checked, "
          "locked or rotated (give --audit-unsafe to log there anyway, or - for standard error)",
          path_, file_kind(st.st_mode)));
    }
    if (S_ISFIFO(st.st_mode)) {
      // Write-only: opened read-write, the monitor would be a reader of its
      // own FIFO, so a departed reader would never be noticed (no EPIPE) and
      // a full pipe would block every check. Without a reader: refused now.
      owned.reset();  // first: open read-write, it would count as the reader
      owned.reset(::open(path_.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK));
      if (!owned.valid()) {
        return make_error(fmt::format("cannot open audit FIFO {}: {}", path_,
                                      errno == ENXIO ? "no process reads it" : strerror(errno)));
      }
    }
    // --audit-unsafe: write(2) per line, blocking (a FIFO reader paces us).
    const int stream = owned.get();
    (void)fcntl(stream, F_SETFL, fcntl(stream, F_GETFL) & ~O_NONBLOCK);
    mode_ = Mode::kStream;
    fd_ = owned.release();
    owned_ = true;
    return {};
  }
  (void)fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  struct statvfs vfs {};
  if (fstatvfs(fd, &vfs) == 0 && (vfs.f_flag & ST_RDONLY) != 0) {
    return make_error("audit log " + path_ + " is on a read-only file system");
  }
  // One writer per log: two would interleave and break the chain.
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    if (err != EWOULDBLOCK) {
      return make_error("cannot lock audit log " + path_ + ": " + strerror(err));
    }
    const std::string holder = lock_holder(st);
    return make_error(fmt::format(
        "audit log {} is in use by another writer{}: two monitors on one log would break its "
        "chain (give each monitor its own --audit file)",
        path_, holder.empty() ? "" : " (" + holder + ")"));
  }
  off_t end = data_end(fd);
  end = complete_end(fd, end);
  // Zero padding and a record torn by a kill are cut off before continuing.
  if (ftruncate(fd, end) != 0) {
    // A file we may not shorten (append-only attribute): keep appending.
  }
  const std::string last = last_line(fd, end);
  if (!last.empty()) sha256_hex(last, prev_);
  // Room for the first records, or a refusal now rather than at the first
  // command: the space is allocated, not just the size set.
  if (const int err = posix_fallocate(fd, end, kStartRoom);
      err == ENOSPC || err == EDQUOT || err == EFBIG) {
    (void)!ftruncate(fd, end);
    return make_error(
        fmt::format("no room for the audit log {} on its file system: {}", path_, strerror(err)));
  }
  base::MutexLock g(grow_mu_);
  fd_ = owned.release();
  owned_ = true;
  dev_ = st.st_dev;
  ino_ = st.st_ino;
  pos_ = end;
  next_check_us_ = monotonic_us() + kCheckEveryUs;
  install_sigbus_guard();
  // A regular file is mapped with its space allocated ahead of the writer:
  // a record is a memcpy into the page cache (no system call), as durable
  // against a killed monitor as write(2) is. A failed mapping: write(2).
  if (map_from_locked(end, 0) && !grower_.joinable()) {
    grower_ = std::thread([this] { grow_ahead(); });
  }
  if (map_ == nullptr) (void)!ftruncate(fd, end);
  return {};
}

void AuditLog::close_file_locked() {
  checked_pos_ = 0;
  if (fd_ < 0) return;
  {
    base::MutexLock g(grow_mu_);
    if (map_ != nullptr) retired_.emplace_back(map_, map_len_);
    map_ = nullptr;
    ready_.store(0, std::memory_order_release);
    written_.store(0, std::memory_order_release);
    file_room_ = 0;
    allocated_.store(0, std::memory_order_release);
    if (mode_ == Mode::kFile) {
      // A clean close removes the padding; a killed monitor leaves it, and
      // the next open() and the verifier skip it. Never grow the file here
      // (it may have been cut under us).
      struct stat st {};
      if (fstat(fd_, &st) == 0 && st.st_size > pos_) (void)!ftruncate(fd_, pos_);
    }
    // The lock goes with the file description, which a retired window
    // still references until the grower unmaps it: release it now.
    if (mode_ == Mode::kFile) (void)flock(fd_, LOCK_UN);
    if (owned_) close(fd_);
    fd_ = -1;
    owned_ = false;
  }
  grow_cv_.notify_one();  // retired windows
}

// Every kCheckEveryUs (or when forced after a failed copy): is the open file
// still the log's path, still linked, not cut? If not, continue the chain
// in the right place: a deleted or moved-away file is replaced by a new
// one at the path; a cut file continues at its new end. Either way the next
// line is a `continues` record. A log that could not be reopened is retried.
void AuditLog::check_file_locked(bool force) {
  if (mode_ != Mode::kFile) return;
  const uint64_t now = monotonic_us();
  if (!force && now < next_check_us_) return;
  next_check_us_ = now + kCheckEveryUs;
  if (fd_ < 0) {  // lost earlier: try again
    char old[65];
    std::memcpy(old, prev_, sizeof old);
    if (open_file_locked().ok()) start_continuation_locked(path_, old, "reopened after a failure");
    return;
  }
  struct stat st {
  }, named{};
  // What the file must hold, read before its size: an extension is
  // published after its fallocate returned, so the size is never behind
  // it (no grow_mu_: the grower may hold it through a long fallocate).
  const size_t allocated = allocated_.load(std::memory_order_acquire);
  if (fstat(fd_, &st) != 0) return;
  const off_t backed = map_ != nullptr ? map_base_ + static_cast<off_t>(allocated) : pos_;
  const bool same =
      stat(path_.c_str(), &named) == 0 && named.st_dev == st.st_dev && named.st_ino == st.st_ino;
  std::string why;
  if (st.st_nlink == 0 || !same) {
    why = st.st_nlink == 0 ? "the log file was deleted" : "the log file was moved away or replaced";
  } else if (st.st_size < backed) {
    why = fmt::format(
        "the log file was cut from {} to {} bytes by another process "
        "(copytruncate?); lines written meanwhile are only in the copy",
        pos_, st.st_size);
  } else if (char c = 1;
             pos_ > 0 && pread(fd_, &c, 1, std::max<off_t>(checked_pos_ - 1, 0)) == 1 && c == 0) {
    // Cut, then its room allocated again by another process's append
    // (the grower no longer does: extend_locked): the size is back, but a
    // byte written before the last check reads as zero now (no line holds
    // one).
    why =
        "the log file was cut by another process (copytruncate?) and its room allocated "
        "again; lines written meanwhile are only in the copy";
  } else {
    checked_pos_ = pos_;
    return;
  }
  const std::string follows = fd_path(fd_);
  char old[65];
  std::memcpy(old, prev_, sizeof old);
  close_file_locked();
  if (Status s = open_file_locked(); !s.ok()) {
    last_error_ = s.error();
    report_failure_locked(why + "; " + s.error());
    return;
  }
  start_continuation_locked(follows, old, why);
}

}  // namespace contego::monitor
