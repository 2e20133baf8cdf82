// The release grid of the per-job bench (see per_job.h), shared by the task
// program and the in-process paths. Header-only, libc alone: the task
// program links nothing else.
//
// Every path's task is released on the same period grid, offset by its
// slot, so that the paths' jobs interleave in one run. The monitor puts a
// task's jobs on a grid of its own, anchored where it first hears of the
// task (its first sleep); start_grid() makes that first sleep happen half a
// period before the first release, so that each job's commands fall in the
// middle of one of the monitor's windows however the start was delayed.
#ifndef CONTEGO_PERF_RELEASE_H_
#define CONTEGO_PERF_RELEASE_H_

#include <errno.h>
#include <time.h>

#include <cstdint>

#include "base/clock.h"

namespace contego::perf {

// Sleeps (CLOCK_MONOTONIC, absolute) until `at_ns`.
inline void sleep_until_ns(uint64_t at_ns) {
  timespec ts{static_cast<time_t>(at_ns / 1000000000u), static_cast<long>(at_ns % 1000000000u)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// The first release at or after `grid_ns` (modulo the period) that leaves
// more than half a period from now; spins (no system call: clock_gettime is
// the vDSO's) until half a period before it and returns it. The caller's
// next sleep is the one that anchors the monitor's job grid.
inline uint64_t start_grid(uint64_t grid_ns, uint64_t period_ns) {
  uint64_t first = grid_ns;
  const uint64_t now = monotonic_ns();
  while (first < now + period_ns / 2 + period_ns / 10) first += period_ns;
  while (monotonic_ns() < first - period_ns / 2) {
  }
  return first;
}

}  // namespace contego::perf

#endif  // CONTEGO_PERF_RELEASE_H_
