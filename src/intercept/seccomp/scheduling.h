// Where and at what priority a supervised program and the thread that
// answers its system calls run: `contego run --cpu N` pins both to one CPU,
// `--rt` puts both under SCHED_FIFO at the task's policy priority.
#ifndef CONTEGO_INTERCEPT_SECCOMP_SCHEDULING_H_
#define CONTEGO_INTERCEPT_SECCOMP_SCHEDULING_H_

#include <sched.h>

#include <sys/types.h>

#include "base/result.h"
#include "intercept/seccomp/supervisor.h"

namespace contego::intercept::seccomp {

// Pins the calling thread to one CPU (a program forked from it and threads
// it starts inherit that), and puts its affinity back when it goes.
class CpuPin {
 public:
  CpuPin() = default;
  CpuPin(const CpuPin&) = delete;
  CpuPin& operator=(const CpuPin&) = delete;
  ~CpuPin();
  // Fails, naming the CPUs allowed, if `cpu` is not one this thread may use.
  Status pin(int cpu);

 private:
  cpu_set_t saved_{};
  bool pinned_ = false;
};

// True if the calling thread may run on one CPU only.
bool on_one_cpu();

// The program and the calling thread (the one that answers its system
// calls) run at options.realtime_priority under SCHED_FIFO, set before the
// program starts (threads and children it creates inherit it). True if this
// thread's scheduling was changed; a refusal is recorded in `result`.
bool apply_priority(const Options& options, pid_t child, RunResult& result);

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_SCHEDULING_H_
