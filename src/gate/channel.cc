#include "gate/channel.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <linux/futex.h>
#include <new>
#include <sys/mman.h>
#include <sys/prctl.h>
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
void futex_wait_ns(std::atomic<uint32_t>* word, uint32_t old, uint64_t timeout_ns) {
  timespec t{static_cast<time_t>(timeout_ns / 1000000000u),
             static_cast<long>(timeout_ns % 1000000000u)};
  syscall(SYS_futex, reinterpret_cast<uint32_t*>(word), FUTEX_WAIT, old, &t, nullptr, 0);
}
void futex_wake(std::atomic<uint32_t>* word) {
  syscall(SYS_futex, reinterpret_cast<uint32_t*>(word), FUTEX_WAKE, 1, nullptr, nullptr, 0);
}

// The one CPU the calling thread may run on, plus 1; 0 if it may run on more.
uint32_t pinned_cpu_plus_one() {
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) != 0 || CPU_COUNT(&set) != 1) return 0;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
    if (CPU_ISSET(cpu, &set)) return static_cast<uint32_t>(cpu) + 1;
  }
  return 0;
}

// A thread that spins for a client pinned to one CPU must not spin on that
// CPU: it would take turns with the client instead of answering it. So the
// calling thread moves off that CPU, when it is on it and has another. It
// keeps all its CPUs: narrowed for good, it would wait out whatever holds
// the CPU left to it (a kernel thread, for ms) with the client's CPU idle,
// where the scheduler's balancing can otherwise move it. (The CPU is the
// client's word: a false one only moves this thread.)
void step_off_cpu(uint32_t cpu_plus_one) {
  if (cpu_plus_one == 0 || cpu_plus_one > CPU_SETSIZE) return;
  const int cpu = static_cast<int>(cpu_plus_one - 1);
  if (sched_getcpu() != cpu) return;
  cpu_set_t mine;
  if (sched_getaffinity(0, sizeof mine, &mine) != 0 || !CPU_ISSET(cpu, &mine) ||
      CPU_COUNT(&mine) < 2) {
    return;
  }
  cpu_set_t elsewhere = mine;
  CPU_CLR(cpu, &elsewhere);
  if (sched_setaffinity(0, sizeof elsewhere, &elsewhere) == 0) {
    // Moved now; it stays there until the scheduler moves it.
    (void)sched_setaffinity(0, sizeof mine, &mine);
  }
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
  return doze_until(word, old, sleeping, UINT64_MAX);
}

bool Channel::doze_until(std::atomic<uint32_t>& word, uint32_t old, std::atomic<uint32_t>& sleeping,
                         uint64_t deadline_ns) {
  for (;;) {
    const uint64_t now = monotonic_ns();
    if (now >= deadline_ns) return true;
    // Announce the sleep, then look again: the other side stores its word
    // before it reads our flag (both seq_cst), so one of us sees the other.
    sleeping.store(1, std::memory_order_seq_cst);
    if (word.load(std::memory_order_seq_cst) != old) break;
    futex_wait_ns(&word, old,
                  std::min<uint64_t>(deadline_ns - now, uint64_t{policy_.poll_ms} * 1000000u));
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
  c.request_posted_ns.store(monotonic_ns(), std::memory_order_relaxed);
  if (!cpu_told_) {  // once: a client is pinned (if at all) before its first request
    cpu_told_ = true;
    c.client_cpu.store(pinned_cpu_plus_one(), std::memory_order_relaxed);
  }
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
  // Spin only while another request is expected soon: a periodic task sends
  // its job's commands in a burst (each within the spin time of the answer
  // before it), and its jobs are alike, so the burst before this one says
  // how many follow. Past that count, spin only for a client that keeps
  // sending back to back. At the predicted end of a job the connection
  // sleeps at once and costs no CPU until the next one. A job-end from the
  // client says so too, whatever the count, once its next job is predicted
  // (without a steady period, a client that follows a job-end closely is
  // sending back to back, and the count decides).
  const bool expected = !(job_ended_ && burst_period_ns_ > 0) &&
                        (burst_taken_ < last_burst_ || (bursting_ && burst_taken_ != last_burst_));
  const uint64_t spin_ns = uint64_t{policy_.spin_us} * 1000u;
  uint32_t spin_us = expected ? policy_.spin_us : 0;
  if (!expected && spin_ns > 0 && burst_period_ns_ > 0) {
    // A client whose bursts start a steady period apart (a periodic task's
    // jobs): sleep until the spin time before the next one is due, then
    // spin through it, so that its first request finds this thread awake
    // instead of paying a wake-up (tens of µs on a virtual machine).
    if (!slack_set_) {
      slack_set_ = true;
      // The default 50 µs of timer slack would spend half the lead.
      (void)prctl(PR_SET_TIMERSLACK, 1ul, 0ul, 0ul, 0ul);
    }
    const uint64_t due = burst_started_ns_ + burst_period_ns_;
    if (!doze_until(c.request_seq, last_seq_, c.server_sleeping, due - std::min(due, spin_ns))) {
      return Next::kClosed;
    }
    // Woken where the scheduler chose; the spin belongs off the client's CPU.
    step_off_cpu(c.client_cpu.load(std::memory_order_relaxed));
    spin_us = 2 * policy_.spin_us;
  }
  if (!wait_change(c.request_seq, last_seq_, c.server_sleeping, spin_us, nullptr)) {
    return Next::kClosed;
  }
  // When the client posted (its word, bounded by when we took it): a thread
  // woken from its sleep takes a request late, and a prediction from that
  // would stay late by the wake-up time.
  const uint64_t taken = monotonic_ns();
  const uint64_t posted = std::clamp<uint64_t>(c.request_posted_ns.load(std::memory_order_relaxed),
                                               std::min(taken, answered_at_ns_), taken);
  bursting_ = posted - std::min(posted, answered_at_ns_) <= spin_ns;
  if (bursting_ || !note_burst_start(posted)) {
    ++burst_taken_;  // the same job: its count goes on
  } else {
    last_burst_ = burst_taken_;
    burst_taken_ = 1;
  }
  last_seq_ = c.request_seq.load(std::memory_order_acquire);
  // Read each field once; the client may be rewriting them as we go.
  const uint32_t t = c.request_type.load(std::memory_order_relaxed);
  const uint32_t len = c.request_len.load(std::memory_order_relaxed);
  *claimed_len = len;
  *type = t <= 0xFF ? static_cast<uint8_t>(t) : 0;
  job_ended_ = t == static_cast<uint32_t>(wire::Type::kJobEnd);
  if (len > kSlotSize) return Next::kOversized;
  payload->resize(len);
  if (len > 0) std::memcpy(payload->data(), request_slot(), len);  // the one copy
  return Next::kRequest;
}

bool Channel::note_burst_start(uint64_t posted) {
  const uint64_t period =
      burst_started_ns_ > 0 && posted > burst_started_ns_ ? posted - burst_started_ns_ : 0;
  const uint64_t estimate = period_estimate_ns_;
  // A burst that starts within half a period of the job's start, before the
  // client's job-end, is the same job, its requests spread out (a slow one
  // split the burst): the job's start and the prediction from it stand.
  if (!job_ended_ && estimate > 0 && period < estimate / 2) return false;
  burst_started_ns_ = posted;
  // Each burst starts late by a varying amount (the client's wake-up, its
  // first call's trap). The last start-to-start time carries that twice (a
  // prediction from it would add the jitter of two starts to the next);
  // their running mean carries almost none of it. A period within an eighth
  // of the mean is steady and predicts the next start; one that is not
  // suspends the prediction, and two in a row start a new mean.
  const uint64_t gap = period > estimate ? period - estimate : estimate - period;
  if (period > 0 && estimate > 0 && gap <= estimate / 8) {
    period_estimate_ns_ = estimate - estimate / 8 + period / 8;
    unsteady_periods_ = 0;
    burst_period_ns_ = period_estimate_ns_;
    return true;
  }
  burst_period_ns_ = 0;
  if (estimate == 0 || ++unsteady_periods_ >= 2) {
    period_estimate_ns_ = period;
    unsteady_periods_ = 0;
  }
  return true;
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

Status recv_frame_with_fd(int fd, wire::Header* header, std::vector<uint8_t>* payload,
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
  if (n == 0) return make_error("closed");
  if (n != static_cast<ssize_t>(sizeof raw)) return make_error("truncated header");
  if (msg.msg_flags & MSG_CTRUNC) return make_error("descriptor truncated");
  if (Status st = wire::decode_header(raw, header); !st.ok()) return st;
  payload->resize(header->length);
  size_t off = 0;
  while (off < header->length) {
    const ssize_t m = recv(fd, payload->data() + off, header->length - off, 0);
    if (m < 0 && errno == EINTR) continue;
    if (m <= 0) return make_error("truncated payload");
    off += static_cast<size_t>(m);
  }
  *passed_fd = passed.release();
  return {};
}

}  // namespace contego::gate
