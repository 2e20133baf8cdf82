#include "gate/channel.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <cstring>
#include <linux/futex.h>
#include <new>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>

#include "base/clock.h"

namespace contego::gate {
namespace {

constexpr unsigned kSeals = F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_SEAL;

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

// Shared (not FUTEX_PRIVATE): the word lives in a mapping of another process.
void futex_wait(std::atomic<uint32_t>* word, uint32_t old, uint32_t timeout_ms) {
  timespec t{static_cast<time_t>(timeout_ms / 1000),
             static_cast<long>(timeout_ms % 1000) * 1000000};
  syscall(SYS_futex, reinterpret_cast<uint32_t*>(word), FUTEX_WAIT, old, &t, nullptr, 0);
}
void futex_wake(std::atomic<uint32_t>* word) {
  syscall(SYS_futex, reinterpret_cast<uint32_t*>(word), FUTEX_WAKE, 1, nullptr, nullptr, 0);
}

Result<uint8_t*> map(int fd) {
  void* p = mmap(nullptr, Channel::kSize, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (p == MAP_FAILED) return make_error(std::string("mmap of the channel: ") + strerror(errno));
  return static_cast<uint8_t*>(p);
}

}  // namespace

Result<std::unique_ptr<Channel>> Channel::create(int socket_fd, SpinPolicy policy) {
  base::UniqueFd fd(memfd_create("contego-channel", MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!fd.valid()) return make_error(std::string("memfd_create: ") + strerror(errno));
  if (ftruncate(fd.get(), static_cast<off_t>(kSize)) != 0 ||
      fcntl(fd.get(), F_ADD_SEALS, kSeals) != 0) {
    return make_error(std::string("cannot size and seal the channel: ") + strerror(errno));
  }
  auto base = map(fd.get());
  if (!base) return make_error(base.error());
  new (*base) ChannelControl{};  // the file is zero-filled; make the atomics' lifetime explicit
  return std::unique_ptr<Channel>(new Channel(std::move(fd), socket_fd, *base, policy));
}

Result<std::unique_ptr<Channel>> Channel::attach(int memfd, int socket_fd, SpinPolicy policy) {
  base::UniqueFd owned(memfd);
  struct stat st {};
  const int seals = fcntl(memfd, F_GET_SEALS);
  if (fstat(memfd, &st) != 0 || static_cast<size_t>(st.st_size) != kSize || seals < 0 ||
      (static_cast<unsigned>(seals) & kSeals) != kSeals) {
    return make_error("the monitor's channel has the wrong size or is not sealed");
  }
  auto base = map(memfd);
  if (!base) return make_error(base.error());
  auto c = std::unique_ptr<Channel>(new Channel(std::move(owned), socket_fd, *base, policy));
  // Resume the numbering the monitor has seen (a fresh channel: zero).
  c->last_seq_ = c->control().request_seq.load(std::memory_order_acquire);
  return c;
}

Channel::~Channel() {
  munmap(base_, kSize);  // memfd_ closes after this
}

bool Channel::peer_connected() {
  pollfd p{socket_fd_, POLLIN, 0};
  if (poll(&p, 1, 0) < 0) return errno == EINTR;
  if (p.revents & (POLLHUP | POLLERR | POLLNVAL)) return false;
  if (p.revents & POLLIN) {
    // In channel mode nothing more comes over the socket; readable means an
    // end of stream (or a peer breaking the protocol, which ends it too).
    char c;
    const ssize_t n = recv(socket_fd_, &c, 1, MSG_PEEK | MSG_DONTWAIT);
    return n < 0 && (errno == EAGAIN || errno == EINTR);
  }
  return true;
}

bool Channel::wait_change(std::atomic<uint32_t>& word, uint32_t old,
                          std::atomic<uint32_t>& sleeping, uint32_t spin_us, bool* slept) {
  if (slept != nullptr) *slept = false;
  if (word.load(std::memory_order_acquire) != old) return true;
  if (spin_us > 0) {
    const uint64_t deadline = monotonic_ns() + uint64_t{spin_us} * 1000u;
    for (;;) {
      for (int i = 0; i < 64; ++i) {
        if (word.load(std::memory_order_acquire) != old) return true;
        cpu_relax();
      }
      if (monotonic_ns() >= deadline) break;
      // A spinner gives way to any other thread that is ready on this CPU
      // (a periodic task's wake-up must not queue behind a busy-wait).
      sched_yield();
    }
  }
  if (slept != nullptr) *slept = true;
  for (;;) {
    // Announce the sleep, then look again: the other side stores its word
    // before it reads our flag (both seq_cst), so one of us sees the other.
    sleeping.store(1, std::memory_order_seq_cst);
    if (word.load(std::memory_order_seq_cst) != old) break;
    futex_wait(&word, old, policy_.poll_ms);
    sleeping.store(0, std::memory_order_relaxed);
    if (word.load(std::memory_order_acquire) != old) return true;
    if (!peer_connected()) return false;
  }
  sleeping.store(0, std::memory_order_relaxed);
  return true;
}

bool Channel::post(wire::Type type, std::span<const uint8_t> payload, uint32_t* seq) {
  ChannelControl& c = control();
  if (payload.size() > kSlotSize) return false;
  // The slot is free once the monitor has answered the previous request
  // (a job-end is posted without waiting for its answer).
  if (!await_reply(last_seq_, nullptr, nullptr)) return false;
  if (!payload.empty()) std::memcpy(request_slot(), payload.data(), payload.size());
  c.request_type.store(static_cast<uint32_t>(type), std::memory_order_relaxed);
  c.request_len.store(static_cast<uint32_t>(payload.size()), std::memory_order_relaxed);
  *seq = ++last_seq_;
  c.request_seq.store(*seq, std::memory_order_seq_cst);
  if (c.server_sleeping.load(std::memory_order_seq_cst) != 0) futex_wake(&c.request_seq);
  return true;
}

bool Channel::await_reply(uint32_t seq, uint8_t* type, std::span<const uint8_t>* payload) {
  ChannelControl& c = control();
  for (;;) {
    const uint32_t now = c.reply_seq.load(std::memory_order_acquire);
    if (now == seq) break;
    // Spinning only pays while answers come within the spin time. When they
    // keep not coming (the monitor's thread waits for a CPU on a busy
    // machine), the spin only takes a CPU from someone: sleep straight away
    // for the next kSpinBackoff answers, then try again.
    const bool spin = unanswered_spins_ < kSpinMisses;
    if (!spin && ++skipped_spins_ >= kSpinBackoff) unanswered_spins_ = skipped_spins_ = 0;
    bool slept = false;
    if (!wait_change(c.reply_seq, now, c.client_sleeping, spin ? policy_.spin_us : 0, &slept)) {
      return false;
    }
    if (spin) unanswered_spins_ = slept && policy_.spin_us > 0 ? unanswered_spins_ + 1 : 0;
  }
  if (type != nullptr) *type = static_cast<uint8_t>(c.reply_type.load(std::memory_order_relaxed));
  if (payload != nullptr) {
    const uint32_t len = c.reply_len.load(std::memory_order_relaxed);
    *payload = {reply_slot(), len <= kSlotSize ? len : 0};
  }
  return true;
}

void Channel::hang_up() { futex_wake(&control().request_seq); }

Channel::Next Channel::next_request(uint8_t* type, uint32_t* claimed_len,
                                    std::vector<uint8_t>* payload) {
  ChannelControl& c = control();
  // Spin only for a client that sends back to back: one whose last request
  // came within the spin time of the answer before it. A periodic task's
  // connection sleeps at once and costs no CPU between its jobs.
  const uint32_t spin = bursting_ ? policy_.spin_us : 0;
  if (!wait_change(c.request_seq, last_seq_, c.server_sleeping, spin, nullptr)) {
    return Next::kClosed;
  }
  bursting_ = monotonic_ns() - answered_at_ns_ <= uint64_t{policy_.spin_us} * 1000u;
  last_seq_ = c.request_seq.load(std::memory_order_acquire);
  // Read each field once; the client may be rewriting them as we go.
  const uint32_t t = c.request_type.load(std::memory_order_relaxed);
  const uint32_t len = c.request_len.load(std::memory_order_relaxed);
  *claimed_len = len;
  *type = t <= 0xFF ? static_cast<uint8_t>(t) : 0;
  if (len > kSlotSize) return Next::kOversized;
  payload->resize(len);
  if (len > 0) std::memcpy(payload->data(), request_slot(), len);  // the one copy
  return Next::kRequest;
}

void Channel::answer(uint8_t type, std::span<const uint8_t> payload) {
  ChannelControl& c = control();
  const size_t len = payload.size() <= kSlotSize ? payload.size() : 0;
  if (len > 0) std::memcpy(reply_slot(), payload.data(), len);
  c.reply_type.store(type, std::memory_order_relaxed);
  c.reply_len.store(static_cast<uint32_t>(len), std::memory_order_relaxed);
  c.reply_seq.store(last_seq_, std::memory_order_seq_cst);
  if (c.client_sleeping.load(std::memory_order_seq_cst) != 0) futex_wake(&c.reply_seq);
  answered_at_ns_ = monotonic_ns();
}

namespace {
// Room for the ancillary data of one passed descriptor.
struct OneFdControl {
  alignas(cmsghdr) char bytes[CMSG_SPACE(sizeof(int))] = {};
};

msghdr one_buffer_message(iovec* iov, OneFdControl* control) {
  msghdr msg{};
  msg.msg_iov = iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control->bytes;
  msg.msg_controllen = sizeof control->bytes;
  return msg;
}
}  // namespace

bool send_frame_with_fd(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload,
                        int passed_fd) {
  std::vector<uint8_t> f = wire::frame(type, seq, payload);
  iovec iov{f.data(), f.size()};
  OneFdControl control;
  msghdr msg = one_buffer_message(&iov, &control);
  cmsghdr* h = CMSG_FIRSTHDR(&msg);
  h->cmsg_level = SOL_SOCKET;
  h->cmsg_type = SCM_RIGHTS;
  h->cmsg_len = CMSG_LEN(sizeof(int));
  std::memcpy(CMSG_DATA(h), &passed_fd, sizeof passed_fd);
  ssize_t n;
  do {
    n = sendmsg(fd, &msg, MSG_NOSIGNAL);
  } while (n < 0 && errno == EINTR);
  return n == static_cast<ssize_t>(f.size());  // a small frame goes out whole
}

std::string recv_frame_with_fd(int fd, wire::Header* header, std::vector<uint8_t>* payload,
                               int* passed_fd) {
  *passed_fd = -1;
  uint8_t raw[wire::kHeaderSize];
  iovec iov{raw, sizeof raw};
  OneFdControl control;
  msghdr msg = one_buffer_message(&iov, &control);
  ssize_t n;
  do {
    n = recvmsg(fd, &msg, MSG_WAITALL | MSG_CMSG_CLOEXEC);
  } while (n < 0 && errno == EINTR);
  base::UniqueFd passed;  // closed on every failure below
  for (cmsghdr* h = CMSG_FIRSTHDR(&msg); h != nullptr; h = CMSG_NXTHDR(&msg, h)) {
    if (h->cmsg_level == SOL_SOCKET && h->cmsg_type == SCM_RIGHTS &&
        h->cmsg_len == CMSG_LEN(sizeof(int))) {
      int got;
      std::memcpy(&got, CMSG_DATA(h), sizeof got);
      passed.reset(got);
    }
  }
  if (n == 0) return "closed";
  if (n != static_cast<ssize_t>(sizeof raw)) return "truncated header";
  if (msg.msg_flags & MSG_CTRUNC) return "descriptor truncated";
  if (std::string why = wire::decode_header(raw, header); !why.empty()) return why;
  payload->resize(header->length);
  size_t off = 0;
  while (off < header->length) {
    const ssize_t m = recv(fd, payload->data() + off, header->length - off, 0);
    if (m < 0 && errno == EINTR) continue;
    if (m <= 0) return "truncated payload";
    off += static_cast<size_t>(m);
  }
  *passed_fd = passed.release();
  return {};
}

}  // namespace contego::gate
