#include "sched/simulate.h"

#include <algorithm>
#include <deque>
#include <numeric>

namespace contego::sched {
namespace {

struct Segment {
  Nanos length = 0;
  bool non_preemptive = false;
};

struct Job {
  Nanos release = 0;
  size_t segment = 0;
  Nanos remaining = 0;  // of the current segment
};

std::vector<Segment> job_shape(const Task& t) {
  std::vector<Segment> out;
  const Nanos chunks = t.actuations + 1;
  for (Nanos k = 0; k < chunks; ++k) {
    // Equal chunks; the last takes the remainder so they sum to C_i.
    const Nanos len = k + 1 < chunks ? t.wcet / chunks : t.wcet - (t.wcet / chunks) * (chunks - 1);
    if (len > 0) out.push_back({len, false});
    if (k + 1 < chunks && t.overhead > 0) out.push_back({t.overhead, true});
  }
  return out;
}

}  // namespace

Result<Nanos> hyperperiod(const TaskSet& set, Nanos limit) {
  Nanos h = 1;
  for (const Task& t : set.tasks) {
    const Nanos g = std::gcd(h, t.period);
    Nanos next = 0;
    if (__builtin_mul_overflow(h / g, t.period, &next) || next > limit) {
      return make_error("hyperperiod exceeds " + format_duration(limit) +
                        "; simulate a shorter horizon or choose harmonic periods");
    }
    h = next;
  }
  return h;
}

Result<SimResult> simulate(const TaskSet& set, const SimOptions& options) {
  if (Status st = validate(set); !st.ok()) return make_error(st.error());
  const size_t n = set.tasks.size();
  if (!options.offsets.empty() && options.offsets.size() != n) {
    return make_error("simulate: one offset per task expected");
  }
  for (const Task& t : set.tasks) {
    if (t.overhead < 0) return make_error("simulate: task '" + t.name + "' has no overhead set");
  }
  Result<Nanos> h = hyperperiod(set, options.max_hyperperiod);
  if (!h) return make_error(h.error());
  Nanos max_offset = 0;
  for (Nanos o : options.offsets) {
    if (o < 0) return make_error("simulate: negative offset");
    max_offset = std::max(max_offset, o);
  }
  const Nanos horizon = options.horizon > 0 ? options.horizon : sat_add(max_offset, *h);

  std::vector<std::vector<Segment>> shape(n);
  for (size_t i = 0; i < n; ++i) shape[i] = job_shape(set.tasks[i]);
  std::vector<std::deque<Job>> pending(n);
  std::vector<Nanos> next_release(n, 0);
  for (size_t i = 0; i < n && !options.offsets.empty(); ++i) next_release[i] = options.offsets[i];

  SimResult out;
  out.hyperperiod = *h;
  out.tasks.resize(n);
  constexpr size_t kNone = static_cast<size_t>(-1);
  size_t running = kNone;
  Nanos now = 0;
  while (true) {
    // Release every job due now.
    Nanos upcoming = kMaxDuration * 4;  // next release time still inside the horizon
    for (size_t i = 0; i < n; ++i) {
      if (next_release[i] == now && now < horizon) {
        pending[i].push_back({now, 0, shape[i].empty() ? 0 : shape[i][0].length});
        ++out.tasks[i].jobs;
        next_release[i] += set.tasks[i].period;
      }
      if (next_release[i] < horizon) upcoming = std::min(upcoming, next_release[i]);
    }
    // Pick the job to run.
    const bool locked = running != kNone && !pending[running].empty() &&
                        shape[running][pending[running].front().segment].non_preemptive &&
                        pending[running].front().remaining <
                            shape[running][pending[running].front().segment].length;
    if (!locked) {
      size_t best = kNone;
      for (size_t i = 0; i < n; ++i) {
        if (pending[i].empty()) continue;
        if (best == kNone || set.tasks[i].priority > set.tasks[best].priority ||
            (set.tasks[i].priority == set.tasks[best].priority &&
             pending[i].front().release < pending[best].front().release)) {
          best = i;
        }
      }
      // SCHED_FIFO: an equal-priority arrival does not preempt.
      if (best != kNone && running != kNone && !pending[running].empty() &&
          set.tasks[running].priority == set.tasks[best].priority) {
        best = running;
      }
      running = best;
    }
    if (running == kNone) {
      if (upcoming >= horizon) break;  // nothing pending, nothing more to release
      now = upcoming;
      continue;
    }
    Job& job = pending[running].front();
    const Nanos segment_end = now + job.remaining;
    const Nanos until = std::min(segment_end, upcoming < horizon ? upcoming : segment_end);
    job.remaining -= until - now;
    now = until;
    if (job.remaining == 0) {
      ++job.segment;
      if (job.segment < shape[running].size()) {
        job.remaining = shape[running][job.segment].length;
      } else {
        const Nanos response = now - job.release;
        SimTaskStats& st = out.tasks[running];
        st.max_response = std::max(st.max_response, response);
        if (response > set.tasks[running].deadline) ++st.misses;
        pending[running].pop_front();
      }
    }
  }
  return out;
}

}  // namespace contego::sched
