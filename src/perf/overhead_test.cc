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

TEST(SchedOverhead, StatisticsOfTheMonitorProcessPathOnAllowedRows) {
  Report r;
  r.trials = 10;
  Row base{"w", Path::kUnprotected, {}, 0, {}};
  base.stats.worst_us = 2.0;
  base.stats.p999_us = 1.0;
  Row mon{"w", Path::kSeccompMonitor, {}, 0, {{"allow", 10}}};
  mon.stats.worst_us = 42.5;
  mon.stats.p999_us = 11.0;
  mon.stats.p99_us = 8.0;
  Row inproc{"w", Path::kSeccompInProcess, {}, 0, {{"allow", 10}}};
  inproc.stats.worst_us = 400.0;  // not the deployment path: ignored
  // A workload whose commands were mostly ignored: not an allowed command's cost.
  Row ignored_base{"v", Path::kUnprotected, {}, 0, {}};
  Row ignored{"v", Path::kSeccompMonitor, {}, 0, {{"allow", 3}, {"ignore", 7}}};
  ignored.stats.worst_us = 900.0;
  ignored.stats.p999_us = 900.0;
  r.rows = {base, mon, inproc, ignored_base, ignored};
  const nlohmann::json j = sched_overhead(r);
  EXPECT_EQ(j["statistic"], "p999");
  EXPECT_EQ(j["overhead_ns"].get<int64_t>(), 10000);  // p99.9: 11 - 1 µs
  EXPECT_EQ(j["statistics_ns"]["max"].get<int64_t>(), 40500);
  EXPECT_EQ(j["statistics_ns"]["p99"].get<int64_t>(), 8000);
  // With no allowed row at all, every row counts (and the method says so).
  r.rows = {ignored_base, ignored};
  EXPECT_EQ(sched_overhead(r)["statistics_ns"]["max"].get<int64_t>(), 900000);
}

TEST(Row, AllAllowedOnlyWhenEveryDecisionIsAllow) {
  Row row{"w", Path::kSeccompMonitor, {}, 0, {{"allow", 10}}};
  EXPECT_TRUE(row.all_allowed());
  row.decisions["failsafe"] = 1;
  EXPECT_FALSE(row.all_allowed());
  row.decisions = {};
  EXPECT_FALSE(row.all_allowed());  // nothing checked
  row.decisions = {{"allow", 10}};
  row.failures = 1;
  EXPECT_FALSE(row.all_allowed());
}

TEST(Summarise, P999) {
  std::vector<uint64_t> ns;
  for (uint64_t i = 1; i <= 2000; ++i) ns.push_back(i * 1000);
  EXPECT_DOUBLE_EQ(summarise(ns).p999_us, 1998.0);
}

}  // namespace
}  // namespace contego::perf
