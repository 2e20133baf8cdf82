// Real-time scheduling for the threads that act for a control task: the
// policy gives each task a fixed priority (larger = more important, as
// SCHED_FIFO), and the program, the supervisor thread that handles its
// system calls and the monitor thread that checks its commands all run at
// it, so a lower-priority task flooding the monitor cannot delay them (the
// paper's model: the check runs on the task's behalf, at its priority).
#ifndef CONTEGO_BASE_REALTIME_H_
#define CONTEGO_BASE_REALTIME_H_

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cstring>
#include <string>

#include "base/result.h"

namespace contego {

// SCHED_FIFO priorities used: 1..98 (99 is left to the kernel's own threads).
inline int fifo_priority(int policy_priority) { return std::clamp(policy_priority, 1, 98); }

// Puts the calling thread under SCHED_FIFO at `policy_priority` (clamped).
// Ok, or why not (EPERM without CAP_SYS_NICE or an RLIMIT_RTPRIO).
inline Status make_thread_realtime(int policy_priority) {
  sched_param p{};
  p.sched_priority = fifo_priority(policy_priority);
  const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
  if (rc != 0) return make_error(std::strerror(rc));
  return {};
}

}  // namespace contego

#endif  // CONTEGO_BASE_REALTIME_H_
