// What the simulation tests read from a run: one of its metrics by name.
#ifndef CONTEGO_SIM_TEST_METRIC_H_
#define CONTEGO_SIM_TEST_METRIC_H_

#include <gtest/gtest.h>
#include <string>

#include "sim/runner.h"

namespace contego::sim::testing {

// The value of the metric `name` of `r`; fails the test (and is 0) if `r` has none.
inline double metric(const RunResult& r, const std::string& name) {
  for (const auto& m : r.metrics) {
    if (m.name == name) return m.value;
  }
  ADD_FAILURE() << "no metric " << name;
  return 0;
}

}  // namespace contego::sim::testing

#endif  // CONTEGO_SIM_TEST_METRIC_H_
