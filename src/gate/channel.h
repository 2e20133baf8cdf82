// Channel: the shared-memory fast path of the gate protocol.
//
// A Unix-socket round trip to another process costs each side a send and a
// receive and, worse, a wake-up of a thread sleeping on the other vCPU. Once
// a client has said hello, it may ask for a channel: the monitor creates a
// sealed memfd with one request slot and one reply slot, passes it over the
// socket (SCM_RIGHTS), and from then on the same wire payloads travel through
// the shared memory. Each side spins for a bounded time (SpinPolicy) before
// it sleeps on a futex, so back-to-back commands cross without any system
// call, and an idle connection costs no CPU.
//
// Trust: the memory is writable by the client. The monitor reads each
// request's type and length once, bounds-checks the length and copies the
// payload into its own buffer before decoding it (one copy, then never the
// shared bytes again). The seals (no shrink, no grow) keep a client from
// truncating the file under the monitor's mapping. A client that scribbles
// over the control words only delays itself: every futex wait has a timeout,
// after which the socket is polled to see whether the peer is still there.
//
// The socket stays open for the channel's lifetime: it is how each side
// learns that the other one is gone (POLLHUP), and a closed socket ends the
// session as before (the monitor drives the task's actuators safe).
//
// Thread-safety: one client thread and one server thread per channel.
#ifndef CONTEGO_GATE_CHANNEL_H_
#define CONTEGO_GATE_CHANNEL_H_

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "base/result.h"
#include "base/unique_fd.h"
#include "gate/wire.h"

namespace contego::gate {

// How long each side busy-waits before it sleeps on the futex. The client
// spins for its answer (a monitor thread that was asleep takes tens of µs
// to wake on a virtual machine; a second sleep would double that). The
// monitor spins for the next request only while the client sends back to
// back (its last request came within spin_us of the answer before it);
// between a periodic task's jobs it sleeps. Spinners yield the CPU to any
// other ready thread, and a client whose spins keep ending asleep (a busy
// machine) stops spinning for a while.
inline constexpr uint32_t kMaxSpinUs = 100000;  // longer spins are a configuration mistake

struct SpinPolicy {
  uint32_t spin_us = 100;  // 0: never spin
  uint32_t poll_ms = 20;   // futex sleep between checks that the peer is still connected
};

// The first page of the shared file. Every field is an atomic: the other
// process may write any of them at any time.
struct ChannelControl {
  alignas(64) std::atomic<uint32_t> request_seq;  // client: bumped after a request is written
  std::atomic<uint32_t> request_type;
  std::atomic<uint32_t> request_len;
  // client: CLOCK_MONOTONIC ns at the post (for the monitor's spin timing only)
  alignas(8) std::atomic<uint64_t> request_posted_ns;
  // client: the one CPU its thread is pinned to, plus 1 (0: not pinned)
  std::atomic<uint32_t> client_cpu;
  alignas(64) std::atomic<uint32_t> reply_seq;  // server: the request seq it answered
  std::atomic<uint32_t> reply_type;
  std::atomic<uint32_t> reply_len;
  alignas(64) std::atomic<uint32_t> server_sleeping;  // server waits on request_seq's futex
  alignas(64) std::atomic<uint32_t> client_sleeping;  // client waits on reply_seq's futex
};
static_assert(std::atomic<uint32_t>::is_always_lock_free);
static_assert(std::atomic<uint64_t>::is_always_lock_free);
// The offsets docs/gate-protocol.md gives.
static_assert(offsetof(ChannelControl, request_seq) == 0 &&
              offsetof(ChannelControl, request_posted_ns) == 16 &&
              offsetof(ChannelControl, client_cpu) == 24 &&
              offsetof(ChannelControl, reply_seq) == 64 &&
              offsetof(ChannelControl, server_sleeping) == 128 &&
              offsetof(ChannelControl, client_sleeping) == 192);

class Channel {
 public:
  static constexpr size_t kControlSize = 4096;
  static constexpr size_t kSlotSize = wire::kMaxPayload;
  static constexpr size_t kSize = kControlSize + 2 * kSlotSize;

  // Monitor side: a new sealed memfd, mapped. `socket_fd` (not owned) is
  // the connection's socket, polled to detect a vanished peer.
  static Result<std::unique_ptr<Channel>> create(int socket_fd, SpinPolicy policy);
  // Client side: maps the descriptor the monitor sent (taking ownership);
  // refuses one of the wrong size or without the seals.
  static Result<std::unique_ptr<Channel>> attach(int memfd, int socket_fd, SpinPolicy policy);
  ~Channel();
  Channel(const Channel&) = delete;
  Channel& operator=(const Channel&) = delete;

  int memfd() const { return memfd_.get(); }

  // --- client ---
  // Waits until the previous request was answered, then writes this one.
  // False if the peer is gone (then nothing was posted).
  bool post(wire::Type type, std::span<const uint8_t> payload, uint32_t* seq);
  // Waits for the answer to `seq`; *payload points into the shared memory
  // and stays valid until the next post. False if the peer is gone.
  bool await_reply(uint32_t seq, uint8_t* type, std::span<const uint8_t>* payload);
  // After the client shut its socket down: wakes a sleeping server thread so
  // that it sees the hang-up now rather than at its next poll.
  void hang_up();

  // --- server ---
  enum class Next { kRequest, kOversized, kClosed };
  // Waits for the next request and copies it into *payload (resized). A
  // request longer than a slot is kOversized (answer it with an error); the
  // peer's socket closing (or shut down by Server::stop) is kClosed.
  Next next_request(uint8_t* type, uint32_t* claimed_len, std::vector<uint8_t>* payload);
  // Answers the request next_request() returned last.
  void answer(uint8_t type, std::span<const uint8_t> payload);

 private:
  Channel(base::UniqueFd memfd, int socket_fd, uint8_t* base, SpinPolicy policy)
      : memfd_(std::move(memfd)), socket_fd_(socket_fd), base_(base), policy_(policy) {}
  ChannelControl& control() { return *reinterpret_cast<ChannelControl*>(base_); }
  uint8_t* request_slot() { return base_ + kControlSize; }
  uint8_t* reply_slot() { return base_ + kControlSize + kSlotSize; }
  // Waits while `word` == `old`: spins, then sleeps on its futex announcing
  // it in `sleeping`. False if the peer went away meanwhile.
  // *slept (if given): whether it had to sleep on the futex.
  bool wait_change(std::atomic<uint32_t>& word, uint32_t old, std::atomic<uint32_t>& sleeping,
                   uint32_t spin_us, bool* slept);
  bool peer_connected();
  // Sleeps until `word` leaves `old` or monotonic time `deadline_ns`, whichever
  // is first, announcing it in `sleeping`. False if the peer went away.
  bool doze_until(std::atomic<uint32_t>& word, uint32_t old, std::atomic<uint32_t>& sleeping,
                  uint64_t deadline_ns);
  // Server: a request posted at `posted` (monotonic ns) did not follow its
  // predecessor closely. True if it starts a new job (the period estimate
  // and the prediction of the next start updated), false if it belongs to
  // the job under way.
  bool note_burst_start(uint64_t posted);

  base::UniqueFd memfd_;  // closed after the destructor unmaps the channel
  int socket_fd_;
  uint8_t* base_;
  SpinPolicy policy_;
  uint32_t last_seq_ = 0;                        // client: last posted; server: last taken
  static constexpr uint32_t kSpinMisses = 8;     // spins in a row that end asleep...
  static constexpr uint32_t kSpinBackoff = 256;  // ...stop spinning for this many answers
  uint32_t unanswered_spins_ = 0;                // client: spins in a row that ended asleep
  uint32_t skipped_spins_ = 0;       // client: answers awaited without spinning since then
  bool bursting_ = false;            // server: the last request followed its predecessor closely
  bool job_ended_ = false;           // server: the last request was the client's job-end
  uint32_t burst_taken_ = 0;         // server: requests taken in the current burst
  uint32_t last_burst_ = 0;          // server: requests in the burst before it
  uint64_t burst_started_ns_ = 0;    // server: when the current burst's first request was posted
  uint64_t period_estimate_ns_ = 0;  // server: mean time between bursts' starts
  uint32_t unsteady_periods_ = 0;    // server: periods in a row off that mean
  uint64_t burst_period_ns_ = 0;     // server: that mean, when steady (else 0: no prediction)
  bool cpu_told_ = false;            // client: client_cpu written
  bool slack_set_ = false;           // server: timer slack lowered for its doze
  uint64_t answered_at_ns_ = 0;      // server: when the last answer was written
};

// Sends / receives one frame carrying a descriptor (SCM_RIGHTS): the
// kChannelOk answer. recv_frame_with_fd reads exactly one frame.
bool send_frame_with_fd(int fd, wire::Type type, uint32_t seq, std::span<const uint8_t> payload,
                        int passed_fd);
Status recv_frame_with_fd(int fd, wire::Header* header, std::vector<uint8_t>* payload,
                          int* passed_fd);

}  // namespace contego::gate

#endif  // CONTEGO_GATE_CHANNEL_H_
