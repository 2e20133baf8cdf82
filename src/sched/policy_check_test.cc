#include "sched/policy_check.h"

#include <gtest/gtest.h>

#include "sched/test_util.h"

namespace contego::sched {
namespace {

using testing::issue_example;
using testing::ms;
using testing::us;

std::vector<std::string> codes(const std::vector<SchedWarning>& w) {
  std::vector<std::string> out;
  for (const SchedWarning& x : w) out.push_back(x.code + ":" + x.task);
  return out;
}

TEST(PolicyCheckTest, SchedulablePolicyWithConsistentLimitsIsQuiet) {
  const auto w = check_policy_tasks(issue_example(), {{"t2", "gopigo", 2}, {"t1", "arm", 1}});
  EXPECT_TRUE(w.empty()) << codes(w).front();
}

TEST(PolicyCheckTest, RateLimitAboveActuationsWarns) {
  const auto w = check_policy_tasks(issue_example(), {{"t1", "gopigo", 3}});
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].code, "rate-above-actuations");
  EXPECT_EQ(w[0].task, "t1");
  EXPECT_NE(w[0].message.find("3 per job on gopigo exceeds the task's 1"), std::string::npos)
      << w[0].message;
}

// At C^o = 2 ms t1 has C^TEE = 3 and B = 2 * 2 = 4: R = 7 > 4.
TEST(PolicyCheckTest, UnschedulableAtConfiguredOverheadWarnsPerTask) {
  const auto w = check_policy_tasks(issue_example(), {}, ms(2));
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w[0].code, "unschedulable");
  EXPECT_EQ(w[0].task, "t1");
  EXPECT_NE(w[0].message.find("exceeds 7ms > deadline 4ms at 2ms"), std::string::npos)
      << w[0].message;
}

TEST(PolicyCheckTest, MissingOverheadIsReported) {
  TaskSet s = issue_example();
  for (Task& t : s.tasks) t.overhead = kOverheadUnset;
  const auto w = check_policy_tasks(s, {});
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].code, "no-overhead");
  s.overhead = us(20);
  EXPECT_TRUE(check_policy_tasks(s, {}).empty());
}

TEST(PolicyCheckTest, InvalidModelIsReportedNotAnalysed) {
  TaskSet s = issue_example();
  s.tasks[0].deadline = ms(5);  // beyond its 4 ms period
  const auto w = check_policy_tasks(s, {});
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].code, "invalid");
  EXPECT_NE(w[0].message.find("exceeds period"), std::string::npos);
}

}  // namespace
}  // namespace contego::sched
