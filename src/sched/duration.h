// Durations for the schedulability analysis: signed 64-bit integer
// nanoseconds throughout, so every figure the analysis prints is exact and
// reproducible (no floating point in any decision).
//
// Host code. Thread-safe (no shared state).
#ifndef CONTEGO_SCHED_DURATION_H_
#define CONTEGO_SCHED_DURATION_H_

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "base/result.h"

namespace contego::sched {

using Nanos = int64_t;

inline constexpr Nanos kNanosPerMicro = 1'000;
inline constexpr Nanos kNanosPerMilli = 1'000'000;
inline constexpr Nanos kNanosPerSecond = 1'000'000'000;

// The largest duration an input may carry: 10^6 s (about 11.6 days). Far
// beyond any control period, and small enough that N * C^o and a few sums of
// such values cannot overflow int64 before the analysis' own guards see them.
inline constexpr Nanos kMaxDuration = 1'000'000 * kNanosPerSecond;

// Parses "<decimal><unit>" with unit ns, us (or µs), ms or s: "1ms", "250us",
// "2.5ms", "1s", "500ns", "0". The value must be a whole number of
// nanoseconds ("0.5ns" is refused), non-negative and at most kMaxDuration.
// A bare number other than 0 is refused: a duration without a unit is a bug
// waiting to happen.
Result<Nanos> parse_duration(std::string_view text);

// Shortest exact spelling in the largest unit that keeps it readable:
// 2500000 -> "2.5ms", 20000 -> "20us", 1500 -> "1.5us", 0 -> "0".
// parse_duration(format_duration(x)) == x for every 0 <= x <= kMaxDuration.
std::string format_duration(Nanos ns);

// a + b and a * b, clamped to INT64_MAX instead of overflowing (inputs >= 0).
inline Nanos sat_add(Nanos a, Nanos b) {
  Nanos r = 0;
  return __builtin_add_overflow(a, b, &r) ? std::numeric_limits<Nanos>::max() : r;
}
inline Nanos sat_mul(Nanos a, Nanos b) {
  Nanos r = 0;
  return __builtin_mul_overflow(a, b, &r) ? std::numeric_limits<Nanos>::max() : r;
}

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_DURATION_H_
