// libcontego_preload.so: the LD_PRELOAD enclave client.
//
// Wraps the C library's open family, ioctl, read, write, close, the dup
// family and the periodic sleeps. A /dev/i2c-N path never reaches the
// kernel: the program gets a placeholder descriptor (/dev/null) and every
// ioctl/read/write on it is decoded by the same i2c_abi code the seccomp
// supervisor uses, sent to the monitor over the gate socket protocol, and
// answered from the monitor's reply. Every other call goes straight to the
// C library after one table look-up.
//
// Configuration (environment): CONTEGO_SOCKET (default
// /run/contego/monitor.sock), CONTEGO_TASK (the task name in the policy),
// CONTEGO_CHANNEL=0 (socket only, no shared-memory channel) and
// CONTEGO_SPIN_US (busy-wait for an answer this long before sleeping).
// Without a task name, or with the monitor unreachable, opening a bus fails
// with EACCES; a lost monitor makes every later transfer fail with EIO.
//
// This client is faster than the seccomp supervisor but bypassable: a
// statically linked program, a raw syscall instruction, or a program that
// clears LD_PRELOAD never passes through it. Use it only for trusted-but-
// buggy code; the seccomp client is the enforcement boundary.
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "gate/socket.h"
#include "gate/socket_client.h"
#include "intercept/i2c_abi/bus_name.h"
#include "intercept/i2c_abi/i2c_abi.h"

namespace {

using namespace contego;

template <typename F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

struct Real {
  int (*open)(const char*, int, ...) = next<int (*)(const char*, int, ...)>("open");
  int (*open64)(const char*, int, ...) = next<int (*)(const char*, int, ...)>("open64");
  int (*openat)(int, const char*, int, ...) = next<int (*)(int, const char*, int, ...)>("openat");
  int (*openat64)(int, const char*, int,
                  ...) = next<int (*)(int, const char*, int, ...)>("openat64");
  int (*ioctl)(int, unsigned long, ...) = next<int (*)(int, unsigned long, ...)>("ioctl");
  ssize_t (*read)(int, void*, size_t) = next<ssize_t (*)(int, void*, size_t)>("read");
  ssize_t (*write)(int, const void*, size_t) = next<ssize_t (*)(int, const void*, size_t)>("write");
  int (*close)(int) = next<int (*)(int)>("close");
  int (*dup)(int) = next<int (*)(int)>("dup");
  int (*dup2)(int, int) = next<int (*)(int, int)>("dup2");
  int (*dup3)(int, int, int) = next<int (*)(int, int, int)>("dup3");
  int (*nanosleep)(const timespec*,
                   timespec*) = next<int (*)(const timespec*, timespec*)>("nanosleep");
  int (*clock_nanosleep)(clockid_t, int, const timespec*, timespec*) =
      next<int (*)(clockid_t, int, const timespec*, timespec*)>("clock_nanosleep");
};

Real& real() {
  static Real r;
  return r;
}

// What i2c-dev keeps per open file; shared by dup()s.
struct Handle {
  std::mutex mu;
  intercept::i2c_abi::FdState state;
};

// The descriptor table and the monitor connection. Leaked on purpose: the
// wrappers may run during static destruction (atexit handlers closing files).
struct State {
  std::mutex mu;
  std::unordered_map<int, std::shared_ptr<Handle>> fds;
  std::atomic<size_t> count{0};  // fds.size(), read without the lock on the fast path
  std::unique_ptr<gate::SocketClient> client;
  bool warned = false;
};

State& state() {
  static State* s = [] {
    auto* st = new State;
    pthread_atfork([] { state().mu.lock(); }, [] { state().mu.unlock(); },
                   [] {
                     // The child must not share the parent's connection (the
                     // frames would interleave): it reconnects on first use.
                     State& c = state();
                     (void)c.client.release();
                     c.mu.unlock();
                   });
    return st;
  }();
  return *s;
}

std::shared_ptr<Handle> lookup(int fd) {
  State& s = state();
  if (s.count.load(std::memory_order_acquire) == 0) return nullptr;
  std::lock_guard<std::mutex> lk(s.mu);
  auto it = s.fds.find(fd);
  return it == s.fds.end() ? nullptr : it->second;
}

void forget(int fd) {
  State& s = state();
  if (s.count.load(std::memory_order_acquire) == 0) return;
  std::lock_guard<std::mutex> lk(s.mu);
  if (s.fds.erase(fd) != 0) s.count.store(s.fds.size(), std::memory_order_release);
}

void remember(int fd, std::shared_ptr<Handle> h) {
  State& s = state();
  std::lock_guard<std::mutex> lk(s.mu);
  s.fds[fd] = std::move(h);
  s.count.store(s.fds.size(), std::memory_order_release);
}

gate::SocketClient* connected();

// exit(status) or a return from main: the wait status the process will
// have. Killed, crashed or _exit()ed, it says nothing: its session ends at once.
void say_goodbye(int status, void* /*unused*/) {
  if (gate::SocketClient* c = connected(); c != nullptr) c->goodbye((status & 0xFF) << 8);
}

// The connection, made on first use. Null if it cannot be made.
gate::SocketClient* client() {
  State& s = state();
  std::lock_guard<std::mutex> lk(s.mu);
  if (s.client) return s.client.get();
  const char* task = getenv("CONTEGO_TASK");
  const char* path = getenv("CONTEGO_SOCKET");
  if (task == nullptr || *task == 0) {
    if (!s.warned) fprintf(stderr, "contego preload: CONTEGO_TASK is not set; buses refused\n");
    s.warned = true;
    return nullptr;
  }
  // The shared-memory channel unless CONTEGO_CHANNEL=0; CONTEGO_SPIN_US sets
  // how long to busy-wait for an answer before sleeping.
  std::optional<gate::SpinPolicy> channel = gate::SpinPolicy{};
  if (const char* c = getenv("CONTEGO_CHANNEL"); c != nullptr && strcmp(c, "0") == 0) {
    channel.reset();
  }
  if (const char* spin = getenv("CONTEGO_SPIN_US"); spin != nullptr && channel) {
    // Out of range or not a number: the default, with a word on stderr.
    char* end = nullptr;
    const unsigned long us = strtoul(spin, &end, 10);
    if (end != spin && *end == 0 && us <= gate::kMaxSpinUs) {
      channel->spin_us = static_cast<uint32_t>(us);
    } else {
      fprintf(stderr, "contego preload: CONTEGO_SPIN_US='%s' is not 0..%u; using %u\n", spin,
              gate::kMaxSpinUs, channel->spin_us);
    }
  }
  auto c = gate::SocketClient::connect(path != nullptr ? path : "/run/contego/monitor.sock", task,
                                       channel);
  if (!c.ok()) {
    if (!s.warned) fprintf(stderr, "contego preload: %s; buses refused\n", c.error().c_str());
    s.warned = true;
    return nullptr;
  }
  s.client = std::move(*c);
  // The exit's status for the monitor (contego/session_room.h): the i2cset
  // runs of a script that exit cleanly stay one session with the script.
  // Registered once per process image; a fork's child inherits the hook and
  // says goodbye only on a connection of its own.
  static bool hooked = false;
  if (!hooked) hooked = on_exit(say_goodbye, nullptr) == 0;
  return s.client.get();
}

gate::SocketClient* connected() {
  State& s = state();
  std::lock_guard<std::mutex> lk(s.mu);
  return s.client.get();
}

// The bus number a path names, or -1: /dev/i2c-N or /dev/i2c/N after
// removing "." and ".." (symbolic links are not followed: bypassable anyway).
int bus_number(const char* path) {
  if (path == nullptr || path[0] != '/') return -1;
  return intercept::bus_number(intercept::lexical_normalise(path));
}

bool has_mode(int flags) { return (flags & O_CREAT) != 0 || (flags & O_TMPFILE) == O_TMPFILE; }

// -2: not a bus path (the caller opens it normally); else the result.
int open_bus(const char* path, int flags) {
  const int bus = bus_number(path);
  if (bus < 0) return -2;
  gate::SocketClient* c = client();
  if (c == nullptr) {
    errno = EACCES;
    return -1;
  }
  if (!c->has_bus(static_cast<uint8_t>(bus))) {
    errno = ENOENT;
    return -1;
  }
  const int fd = real().open("/dev/null", O_RDWR | (flags & O_CLOEXEC));
  if (fd < 0) return -1;
  auto h = std::make_shared<Handle>();
  h->state.bus = static_cast<uint8_t>(bus);
  remember(fd, std::move(h));
  return fd;
}

int64_t finish(intercept::i2c_abi::Decoded& d, intercept::i2c_abi::Memory& mem) {
  using Action = intercept::i2c_abi::Decoded::Action;
  if (d.action == Action::kReturn) return d.err != 0 ? -d.err : d.value;
  gate::SocketClient* c = client();
  if (c == nullptr) return -EIO;  // fail closed
  const gate::TransferReply r = c->transfer(c->task_id(), d.transfer);
  return intercept::i2c_abi::complete(d.completion, r, mem);
}

template <typename T>
T answer(int64_t v) {
  if (v < 0) {
    errno = static_cast<int>(-v);
    return static_cast<T>(-1);
  }
  return static_cast<T>(v);
}

int bus_ioctl(Handle& h, unsigned long request, uint64_t arg) {
  std::lock_guard<std::mutex> lk(h.mu);
  gate::SocketClient* c = client();
  if (c == nullptr) {
    errno = EIO;
    return -1;
  }
  intercept::i2c_abi::LocalMemory mem;
  auto d = intercept::i2c_abi::decode_ioctl(h.state, request, arg, mem, c->funcs(h.state.bus));
  return answer<int>(finish(d, mem));
}

void job_end() {
  if (gate::SocketClient* c = connected(); c != nullptr) c->job_boundary(c->task_id());
}

}  // namespace

#define CONTEGO_EXPORT extern "C" __attribute__((visibility("default")))

// Declares `mode`: the optional argument after `flags` of open(2) and its
// variants, there only when `flags` create a file (0 otherwise). A macro, as
// va_start must stand in the variadic function itself.
#define CONTEGO_MODE_ARG(flags, mode) \
  mode_t mode = 0;                    \
  if (has_mode(flags)) {              \
    va_list ap;                       \
    va_start(ap, flags);              \
    mode = va_arg(ap, mode_t);        \
    va_end(ap);                       \
  }

CONTEGO_EXPORT int open(const char* path, int flags, ...) {
  CONTEGO_MODE_ARG(flags, mode);
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().open(path, flags, mode);
}

CONTEGO_EXPORT int open64(const char* path, int flags, ...) {
  CONTEGO_MODE_ARG(flags, mode);
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().open64(path, flags, mode);
}

CONTEGO_EXPORT int __open_2(const char* path, int flags) {
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().open(path, flags);
}

CONTEGO_EXPORT int __open64_2(const char* path, int flags) {
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().open64(path, flags);
}

CONTEGO_EXPORT int openat(int dirfd, const char* path, int flags, ...) {
  CONTEGO_MODE_ARG(flags, mode);
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().openat(dirfd, path, flags, mode);
}

CONTEGO_EXPORT int openat64(int dirfd, const char* path, int flags, ...) {
  CONTEGO_MODE_ARG(flags, mode);
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().openat64(dirfd, path, flags, mode);
}

CONTEGO_EXPORT int __openat_2(int dirfd, const char* path, int flags) {
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().openat(dirfd, path, flags);
}

CONTEGO_EXPORT int __openat64_2(int dirfd, const char* path, int flags) {
  if (int r = open_bus(path, flags); r != -2) return r;
  return real().openat64(dirfd, path, flags);
}

CONTEGO_EXPORT int ioctl(int fd, unsigned long request, ...) noexcept {
  va_list ap;
  va_start(ap, request);
  void* arg = va_arg(ap, void*);
  va_end(ap);
  if (auto h = lookup(fd)) return bus_ioctl(*h, request, reinterpret_cast<uint64_t>(arg));
  return real().ioctl(fd, request, arg);
}

CONTEGO_EXPORT ssize_t read(int fd, void* buf, size_t count) {
  auto h = lookup(fd);
  if (!h) return real().read(fd, buf, count);
  std::lock_guard<std::mutex> lk(h->mu);
  intercept::i2c_abi::LocalMemory mem;
  auto d = intercept::i2c_abi::decode_read(h->state, reinterpret_cast<uint64_t>(buf), count);
  return answer<ssize_t>(finish(d, mem));
}

CONTEGO_EXPORT ssize_t write(int fd, const void* buf, size_t count) {
  auto h = lookup(fd);
  if (!h) return real().write(fd, buf, count);
  std::lock_guard<std::mutex> lk(h->mu);
  intercept::i2c_abi::LocalMemory mem;
  auto d = intercept::i2c_abi::decode_write(h->state, reinterpret_cast<uint64_t>(buf), count, mem);
  return answer<ssize_t>(finish(d, mem));
}

CONTEGO_EXPORT int close(int fd) {
  forget(fd);
  return real().close(fd);
}

CONTEGO_EXPORT int dup(int fd) noexcept {
  auto h = lookup(fd);
  const int r = real().dup(fd);
  if (h && r >= 0) remember(r, std::move(h));
  return r;
}

CONTEGO_EXPORT int dup2(int fd, int fd2) noexcept {
  auto h = lookup(fd);
  const int r = real().dup2(fd, fd2);
  if (r >= 0 && fd != fd2) {
    forget(fd2);
    if (h) remember(fd2, std::move(h));
  }
  return r;
}

CONTEGO_EXPORT int dup3(int fd, int fd2, int flags) noexcept {
  auto h = lookup(fd);
  const int r = real().dup3(fd, fd2, flags);
  if (r >= 0) {
    forget(fd2);
    if (h) remember(fd2, std::move(h));
  }
  return r;
}

CONTEGO_EXPORT int nanosleep(const timespec* req, timespec* rem) {
  job_end();
  return real().nanosleep(req, rem);
}

CONTEGO_EXPORT int clock_nanosleep(clockid_t clock, int flags, const timespec* req, timespec* rem) {
  job_end();
  return real().clock_nanosleep(clock, flags, req, rem);
}
