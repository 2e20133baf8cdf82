// The one monotonic clock of the host side, and the clock seam of the
// trusted side: the monitor reads time only through a Clock (as LevelDB's
// Env), so the simulator can drive the real monitor in virtual time.
//
// Thread-safety: every Clock may be read from any thread.
#ifndef CONTEGO_BASE_CLOCK_H_
#define CONTEGO_BASE_CLOCK_H_

#include <errno.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdint>

namespace contego {

// CLOCK_MONOTONIC, in nanoseconds and in microseconds.
inline uint64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1000000000u + static_cast<uint64_t>(ts.tv_nsec);
}
inline uint64_t monotonic_us() { return monotonic_ns() / 1000u; }

class Clock {
 public:
  virtual ~Clock() = default;
  virtual uint64_t now_us() const = 0;
  // Returns once now_us() >= `until_us`.
  virtual void sleep_until_us(uint64_t until_us) = 0;
};

// CLOCK_MONOTONIC: the default of everything that takes a Clock.
class MonotonicClock final : public Clock {
 public:
  uint64_t now_us() const override { return monotonic_us(); }
  void sleep_until_us(uint64_t until_us) override {
    const timespec until{static_cast<time_t>(until_us / 1000000u),
                         static_cast<long>(until_us % 1000000u) * 1000};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
    }
  }
  // The process's one instance.
  static MonotonicClock& instance() {
    static MonotonicClock clock;
    return clock;
  }
};

// Virtual time: moves only when told to. A sleep moves it to the wake-up time.
class ManualClock final : public Clock {
 public:
  explicit ManualClock(uint64_t start_us = 0) : now_us_(start_us) {}
  uint64_t now_us() const override { return now_us_.load(); }
  void sleep_until_us(uint64_t until_us) override { set_us(std::max(now_us(), until_us)); }
  void set_us(uint64_t now_us) { now_us_.store(now_us); }

 private:
  std::atomic<uint64_t> now_us_;
};

}  // namespace contego

#endif  // CONTEGO_BASE_CLOCK_H_
