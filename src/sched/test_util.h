// Helpers shared by the sched unit tests.
#ifndef CONTEGO_SCHED_TEST_UTIL_H_
#define CONTEGO_SCHED_TEST_UTIL_H_

#include <string>

#include "sched/task_set.h"

namespace contego::sched::testing {

constexpr Nanos us(double v) { return static_cast<Nanos>(v * 1e3); }
constexpr Nanos ms(double v) { return static_cast<Nanos>(v * 1e6); }

inline Task task(std::string name, Nanos c, Nanos t, Nanos d, int64_t prio, int64_t n,
                 Nanos overhead) {
  Task x;
  x.name = std::move(name);
  x.wcet = c;
  x.period = t;
  x.deadline = d;
  x.priority = prio;
  x.actuations = n;
  x.overhead = overhead;
  return x;
}

// The example of issue 5, at C^o = 0.5 ms for every task.
inline TaskSet issue_example() {
  TaskSet s;
  s.tasks = {task("t1", ms(1), ms(4), ms(4), 3, 1, us(500)),
             task("t2", ms(2), ms(10), ms(10), 2, 2, us(500)),
             task("t3", ms(3), ms(20), ms(20), 1, 1, us(500))};
  return s;
}

// Blocking dominates: hi: C=1, T=D=3, N=0, prio 2; lo: C=1, T=D=100, N=5,
// prio 1; C^o = `overhead` for both.
inline TaskSet blocking_example(Nanos overhead) {
  TaskSet s;
  s.tasks = {task("hi", ms(1), ms(3), ms(3), 2, 0, overhead),
             task("lo", ms(1), ms(100), ms(100), 1, 5, overhead)};
  return s;
}

}  // namespace contego::sched::testing

#endif  // CONTEGO_SCHED_TEST_UTIL_H_
