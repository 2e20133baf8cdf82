#include "sched/batch.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "sched/analysis.h"
#include "sched/generate.h"
#include "sched/reader.h"
#include "sched/sensitivity.h"

namespace contego::sched {
namespace {

struct Ran {
  BatchSummary summary;
  std::vector<nlohmann::json> lines;
  std::string errors;
};

Ran run(const std::string& text, const BatchOptions& o = {}) {
  std::istringstream in(text);
  std::ostringstream out, err;
  Ran r;
  r.summary = run_batch(in, "stream", o, out, &err);
  std::istringstream lines(out.str());
  std::string line;
  while (std::getline(lines, line)) r.lines.push_back(nlohmann::json::parse(line));
  r.errors = err.str();
  return r;
}

TEST(BatchTest, JsonLinesAndCsvBlocksOneResultEachErrorsNamedByLine) {
  const std::string text =
      R"({"overhead": "0.5ms", "tasks": [{"name": "t1", "wcet": "1ms", "period": "4ms", "priority": 3, "actuations": 1}]})"
      "\n"
      "# a comment between sets\n"
      R"({"tasks": [{"name": "bad", "wcet": "1 fortnight", "period": "4ms", "priority": 1}]})"
      "\n"
      "\n"
      "name,wcet,period,priority,actuations,overhead\n"
      "a,1ms,4ms,2,1,500us\n"
      "b,3ms,5ms,1,1,500us\n"
      "\n"
      "name,wcet,period,priority\n"
      "c,1ms,oops,1\n";
  const Ran r = run(text);
  ASSERT_EQ(r.lines.size(), 4u);
  EXPECT_EQ(r.summary.sets, 4u);
  EXPECT_EQ(r.summary.failed, 2u);
  EXPECT_EQ(r.summary.unschedulable, 1u);
  EXPECT_EQ(r.lines[0]["line"], 1);
  EXPECT_TRUE(r.lines[0]["schedulable"]);
  EXPECT_EQ(r.lines[0]["tasks"][0]["response_ns"], 1'500'000);
  EXPECT_EQ(r.lines[0]["max_overhead_ns"], 3'000'000);  // 1ms + x <= 4ms
  EXPECT_EQ(r.lines[1]["line"], 3);
  EXPECT_NE(r.lines[1]["error"].get<std::string>().find("stream:3"), std::string::npos);
  EXPECT_EQ(r.lines[2]["line"], 5);         // the block's header
  EXPECT_FALSE(r.lines[2]["schedulable"]);  // b: 3.5 + 2 x 1.5 (a) > 5ms
  EXPECT_EQ(r.lines[3]["line"], 9);
  // The CSV reader's own message carries the stream's line number.
  EXPECT_NE(r.lines[3]["error"].get<std::string>().find("stream:10"), std::string::npos)
      << r.lines[3]["error"];
  EXPECT_NE(r.errors.find("stream:3"), std::string::npos);
}

TEST(BatchTest, NoPrioritiesNeedAnAssignment) {
  const std::string text = R"({"tasks": [{"name": "t", "wcet": "1ms", "period": "4ms"}]})"
                           "\n";
  EXPECT_EQ(run(text).summary.failed, 1u);
  BatchOptions o;
  o.assign = Assignment::kDeadlineMonotonic;
  o.overhead = 1000;
  const Ran r = run(text, o);
  EXPECT_EQ(r.summary.failed, 0u);
  EXPECT_EQ(r.lines[0]["tasks"][0]["overhead_ns"], 1000);
}

// A long stream of CSV blocks (and JSON lines) is parsed once, line by
// line: the parsers see no more bytes than the stream holds. Padding each
// block to its line number (so the CSV reader's errors named the stream's
// lines) made --batch quadratic, 4 times slower per doubling of the stream.
TEST(BatchTest, EachLineIsParsedOnceSoALongStreamIsLinear) {
  std::string text;
  for (int k = 0; k < 3000; ++k) {
    text += "# set " + std::to_string(k) + "\n";
    text += "name,wcet,period,priority,actuations,overhead\n";
    text += "a,1ms,4ms,2,1,50us\nb,2ms,10ms,1,2,50us\n\n";
    if (k % 10 == 0) {
      text += R"({"tasks": [{"name": "t", "wcet": "1ms", "period": "4ms", "priority": 1}]})"
              "\n";
    }
  }
  text += "name,wcet,period,priority\nc,1ms,oops,1\n";  // an error still names its line
  BatchOptions o;
  o.sensitivity = false;
  const Ran r = run(text, o);
  EXPECT_EQ(r.summary.sets, 3301u);
  EXPECT_EQ(r.summary.failed, 1u);
  EXPECT_LE(r.summary.parsed_bytes, text.size());
  EXPECT_GT(r.summary.parsed_bytes, text.size() / 2);
  const size_t last_line = 3000 * 5 + 300 + 2;
  EXPECT_NE(r.errors.find("stream:" + std::to_string(last_line)), std::string::npos) << r.errors;
}

nlohmann::json figure(int64_t v) {
  if (v == kUnbounded) return "unbounded";
  if (v == kInfeasible) return "infeasible";
  return v;
}

// The stream gives what the library gives for each set.
TEST(BatchTest, ResultsEqualTheLibraryOnRandomSets) {
  Generator gen(7);
  GenOptions o;
  o.tasks = 8;
  o.constrained = true;
  std::vector<TaskSet> sets;
  std::string text;
  for (int k = 0; k < 200; ++k) {
    TaskSet s = gen.generate(o, 0.4 + 0.003 * k);
    for (size_t i = 0; i < s.tasks.size(); ++i) {
      s.tasks[i].priority = static_cast<int64_t>(i % 5);
      s.tasks[i].overhead = 1000 * static_cast<Nanos>(k % 7);
    }
    text += to_json_line(s);
    sets.push_back(s);
  }
  const Ran r = run(text);
  ASSERT_EQ(r.lines.size(), sets.size());
  int unschedulable = 0;
  for (size_t k = 0; k < sets.size(); ++k) {
    const Analysis a = analyse(sets[k]);
    const Sensitivity sens = sensitivity(sets[k]);
    const nlohmann::json& line = r.lines[k];
    ASSERT_EQ(line["line"], k + 1);
    EXPECT_EQ(line["schedulable"], a.schedulable);
    unschedulable += a.schedulable ? 0 : 1;
    EXPECT_EQ(line["max_overhead_ns"], figure(sens.max_overhead));
    for (size_t i = 0; i < sets[k].tasks.size(); ++i) {
      const nlohmann::json& t = line["tasks"][i];
      EXPECT_EQ(t["schedulable"], a.tasks[i].schedulable);
      EXPECT_EQ(a.tasks[i].schedulable ? t["response_ns"] : t["response_exceeds_ns"],
                a.tasks[i].response);
      EXPECT_EQ(t["min_period_ns"], figure(sens.tasks[i].min_period));
      EXPECT_EQ(t["max_actuations"], figure(sens.tasks[i].max_actuations));
    }
  }
  EXPECT_GT(unschedulable, 10);
  EXPECT_EQ(r.summary.unschedulable, static_cast<size_t>(unschedulable));
}

}  // namespace
}  // namespace contego::sched
