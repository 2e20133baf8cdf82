#include "perf/overhead.h"

#include <gtest/gtest.h>

namespace contego::perf {
namespace {

TEST(Summarise, NearestRankPercentilesOfKnownSamples) {
  std::vector<uint64_t> ns;
  for (uint64_t i = 1; i <= 1000; ++i) ns.push_back(i * 1000);  // 1 .. 1000 µs, shuffled below
  std::swap(ns[0], ns[999]);
  const Stats s = summarise(ns);
  EXPECT_EQ(s.n, 1000u);
  EXPECT_DOUBLE_EQ(s.median_us, 500.0);
  EXPECT_DOUBLE_EQ(s.p99_us, 990.0);
  EXPECT_DOUBLE_EQ(s.worst_us, 1000.0);
  EXPECT_DOUBLE_EQ(s.mean_us, 500.5);
}

TEST(Summarise, OneOutlierIsTheWorstButNotTheP99) {
  std::vector<uint64_t> ns(200, 5000);
  ns[17] = 900000;
  const Stats s = summarise(ns);
  EXPECT_DOUBLE_EQ(s.p99_us, 5.0);
  EXPECT_DOUBLE_EQ(s.worst_us, 900.0);
}

TEST(SchedOverhead, IsTheLargestAddedWorstCaseOfTheMonitorProcessPath) {
  Report r;
  r.trials = 10;
  Row base{"w", Path::kUnprotected, {}, 0, {}};
  base.stats.worst_us = 2.0;
  Row mon{"w", Path::kSeccompMonitor, {}, 0, {}};
  mon.stats.worst_us = 42.5;
  Row inproc{"w", Path::kSeccompInProcess, {}, 0, {}};
  inproc.stats.worst_us = 400.0;  // not the deployment path: ignored
  r.rows = {base, mon, inproc};
  EXPECT_EQ(sched_overhead(r)["overhead_ns"].get<int64_t>(), 40500);
}

}  // namespace
}  // namespace contego::perf
