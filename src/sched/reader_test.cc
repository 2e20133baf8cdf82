#include "sched/reader.h"

#include <gtest/gtest.h>

#include "sched/test_util.h"

namespace contego::sched {
namespace {

using testing::ms;
using testing::us;

void expect_error(const Result<TaskSet>& r, const std::string& fragment) {
  ASSERT_FALSE(r.ok()) << "expected an error containing: " << fragment;
  EXPECT_NE(r.error().find(fragment), std::string::npos) << r.error();
}

TEST(ReaderTest, CsvWithTheDocumentedHeader) {
  const Result<TaskSet> r = parse_csv(
      "# the issue's example\n"
      "name,wcet,period,deadline,priority,actuations\n"
      "t1,1ms,4ms,4ms,3,1\r\n"
      "\n"
      "t2, 2ms, 10ms, 10ms, 2, 2\n"
      "t3,3ms,20ms,,1,1\n",
      "set.csv");
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->tasks.size(), 3u);
  EXPECT_EQ(r->tasks[1].name, "t2");
  EXPECT_EQ(r->tasks[1].wcet, ms(2));
  EXPECT_EQ(r->tasks[1].actuations, 2);
  EXPECT_EQ(r->tasks[2].deadline, ms(20)) << "empty deadline means D = T";
  EXPECT_EQ(r->tasks[0].priority, 3);
  EXPECT_EQ(r->tasks[0].overhead, kOverheadUnset);
  EXPECT_TRUE(r->priorities_given);
}

TEST(ReaderTest, CsvColumnsInAnyOrderAndOptionalOnes) {
  const Result<TaskSet> r = parse_csv("period,name,wcet,overhead\n5ms,a,1ms,20us\n", "x.csv");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->tasks[0].deadline, ms(5));
  EXPECT_EQ(r->tasks[0].overhead, us(20));
  EXPECT_EQ(r->tasks[0].actuations, 0);
  EXPECT_FALSE(r->priorities_given);
}

TEST(ReaderTest, CsvErrorsNameFileLineAndField) {
  expect_error(parse_csv("name,wcet,period\na,1,4ms\n", "s.csv"), "s.csv:2: wcet:");
  expect_error(parse_csv("name,wcet,period\na,1,4ms\n", "s.csv"), "missing unit");
  expect_error(parse_csv("name,wcet,period,prio\n", "s.csv"), "s.csv:1: unknown column 'prio'");
  expect_error(parse_csv("name,wcet\n", "s.csv"), "no 'period' column");
  expect_error(parse_csv("name,wcet,period\na,1ms\n", "s.csv"),
               "s.csv:2: expected 3 fields, found 2");
  expect_error(parse_csv("name,wcet,period,priority\na,1ms,4ms,high\n", "s.csv"),
               "s.csv:2: priority: 'high' is not an integer");
  expect_error(parse_csv("name,wcet,period,actuations\na,1ms,4ms,-1\n", "s.csv"), "actuations");
  expect_error(parse_csv("name,wcet,period\na,1ms,4ms\na,1ms,4ms\n", "s.csv"), "name used twice");
  expect_error(parse_csv("# nothing\n", "s.csv"), "no header");
  expect_error(parse_csv("name,wcet,period\n", "s.csv"), "empty");
}

// A block cut from a longer stream names the stream's lines, without the
// caller padding the block to its offset (that padding made --batch quadratic).
TEST(ReaderTest, CsvBlockFromAStreamNamesTheStreamsLine) {
  expect_error(parse_csv("name,wcet,period\na,1,4ms\n", "stream", 7001), "stream:7002: wcet:");
  expect_error(parse_csv("name,wcet,period,prio\n", "stream", 40), "stream:40: unknown column");
}

TEST(ReaderTest, DeadlineBeyondPeriodIsRefusedClearly) {
  expect_error(parse_csv("name,wcet,period,deadline\nslow,1ms,10ms,15ms\n", "s.csv"),
               "task 'slow': deadline 15ms exceeds period 10ms");
}

TEST(ReaderTest, JsonTaskSet) {
  const Result<TaskSet> r = parse_json(R"({"overhead": "0.5ms", "tasks": [
      {"name": "t1", "wcet": "1ms", "period": "4ms", "priority": 3, "actuations": 1},
      {"name": "t2", "wcet": "2ms", "period": "10ms", "deadline": "8ms", "priority": 2,
       "actuations": 2, "overhead": "40us"}]})",
                                       "set.json");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(*r->overhead, us(500));
  EXPECT_EQ(r->tasks[0].deadline, ms(4));
  EXPECT_EQ(r->tasks[1].deadline, ms(8));
  EXPECT_EQ(r->tasks[1].overhead, us(40));
  EXPECT_TRUE(r->priorities_given);
}

TEST(ReaderTest, JsonLineReadsBackAsTheSameSet) {
  const TaskSet s = testing::issue_example();
  const std::string line = to_json_line(s);
  ASSERT_EQ(line.back(), '\n');
  const Result<TaskSet> r = parse_json(line, "line");
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->tasks.size(), s.tasks.size());
  for (size_t i = 0; i < s.tasks.size(); ++i) {
    EXPECT_EQ(r->tasks[i].name, s.tasks[i].name);
    EXPECT_EQ(r->tasks[i].wcet, s.tasks[i].wcet);
    EXPECT_EQ(r->tasks[i].period, s.tasks[i].period);
    EXPECT_EQ(r->tasks[i].deadline, s.tasks[i].deadline);
    EXPECT_EQ(r->tasks[i].priority, s.tasks[i].priority);
    EXPECT_EQ(r->tasks[i].actuations, s.tasks[i].actuations);
    EXPECT_EQ(r->tasks[i].overhead, s.tasks[i].overhead);
  }
}

TEST(ReaderTest, JsonErrorsNameTaskAndField) {
  expect_error(parse_json(R"({"tasks": [{"name": "a", "wcet": 1000, "period": "4ms"}]})", "j"),
               "tasks[0] ('a').wcet: give a string with a unit");
  expect_error(parse_json(R"({"tasks": [{"name": "a", "wcet": "1ms", "perod": "4ms"}]})", "j"),
               "tasks[0] ('a').perod: unknown key");
  expect_error(parse_json(R"({"tasks": [{"name": "a", "wcet": "1ms"}]})", "j"),
               "missing \"period\"");
  expect_error(parse_json(R"({"tasks": [)", "j"), "not valid JSON");
  expect_error(parse_json(R"({"task": []})", "j"), "unknown key 'task'");
  expect_error(
      parse_json(R"({"tasks": [{"name": "a", "wcet": "1ms", "period": "4ms", "priority": 1},
                                        {"name": "b", "wcet": "1ms", "period": "4ms"}]})",
                 "j"),
      "some tasks have a priority");
}

TEST(ReaderTest, MeasuredOverheadFile) {
  Result<MeasuredOverhead> m = parse_overhead_json(
      R"({"overhead_ns": 41000, "measured_on": "rpi3", "method": "p99 of 10000 trials"})",
      "o.json");
  ASSERT_TRUE(m.ok()) << m.error();
  EXPECT_EQ(m->overhead, us(41));
  EXPECT_EQ(m->measured_on, "rpi3");
  EXPECT_FALSE(parse_overhead_json(R"({"overhead": "41us"})", "o.json").ok());
  EXPECT_FALSE(parse_overhead_json(R"({"overhead_ns": -5})", "o.json").ok());
  // An older file: its one figure by default, no statistic to choose from.
  Result<ChosenOverhead> c = choose_overhead(*m, "", "o.json");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->overhead, us(41));
  EXPECT_EQ(c->statistic, "overhead_ns");
  EXPECT_FALSE(c->worst.has_value());
  c = choose_overhead(*m, "p99", "o.json");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("no statistics_ns"), std::string::npos) << c.error();
}

TEST(ReaderTest, MeasuredOverheadStatisticIsChosenWithTheWorstBeside) {
  Result<MeasuredOverhead> m = parse_overhead_json(
      R"({"overhead_ns": 30000, "statistic": "p999",
          "statistics_ns": {"median": 9000, "p99": 20000, "p999": 30000, "max": 1300000}})",
      "o.json");
  ASSERT_TRUE(m.ok()) << m.error();
  Result<ChosenOverhead> c = choose_overhead(*m, "", "o.json");  // the default: p99.9
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->statistic, "p999");
  EXPECT_EQ(c->overhead, us(30));
  EXPECT_EQ(c->worst, us(1300));
  c = choose_overhead(*m, "max", "o.json");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->overhead, us(1300));
  c = choose_overhead(*m, "p90", "o.json");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().find("the file has max, median, p99, p999"), std::string::npos) << c.error();
  EXPECT_FALSE(
      parse_overhead_json(R"({"overhead_ns": 1, "statistics_ns": {"p99": "20us"}})", "o.json")
          .ok());
}

}  // namespace
}  // namespace contego::sched
