#include "intercept/seccomp/scheduling.h"

#include <errno.h>

#include <cstring>
#include <string>

#include "base/realtime.h"

namespace contego::intercept::seccomp {
namespace {

std::string cpu_list(const cpu_set_t& set) {
  std::string out;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &set)) out += (out.empty() ? "CPUs " : ",") + std::to_string(c);
  }
  return out.empty() ? "no CPU" : out;
}

}  // namespace

Status CpuPin::pin(int cpu) {
  if (sched_getaffinity(0, sizeof saved_, &saved_) != 0) {
    return make_error(std::string("sched_getaffinity: ") + strerror(errno));
  }
  if (cpu < 0 || cpu >= CPU_SETSIZE || !CPU_ISSET(cpu, &saved_)) {
    return make_error("CPU " + std::to_string(cpu) + " is not one this process may run on (" +
                      cpu_list(saved_) + ")");
  }
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  if (sched_setaffinity(0, sizeof one, &one) != 0) {
    return make_error("CPU " + std::to_string(cpu) + ": sched_setaffinity: " + strerror(errno));
  }
  pinned_ = true;
  return {};
}

CpuPin::~CpuPin() {
  if (pinned_) (void)sched_setaffinity(0, sizeof saved_, &saved_);
}

bool on_one_cpu() {
  cpu_set_t set;
  return sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) == 1;
}

bool apply_priority(const Options& options, pid_t child, RunResult& result) {
  if (options.realtime_priority <= 0) return false;
  sched_param p{};
  p.sched_priority = fifo_priority(options.realtime_priority);
  if (sched_setscheduler(child, SCHED_FIFO, &p) != 0) {
    result.realtime_error = std::string("SCHED_FIFO for the program: ") + strerror(errno);
    return false;
  }
  if (Status st = make_thread_realtime(options.realtime_priority); !st.ok()) {
    result.realtime_error = "SCHED_FIFO for the supervisor: " + st.error();
    return false;
  }
  result.realtime = true;
  return true;
}

}  // namespace contego::intercept::seccomp
