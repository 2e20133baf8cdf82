// Runs the built `contego sched` on task-set files and checks what a user
// (or a script) sees: the JSON, the exit status, the error text.
#include <array>
#include <cstdio>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <string>
#include <sys/wait.h>
#include <vector>

namespace {

struct CliRun {
  int status = -1;
  std::string out;  // stdout and stderr
};

CliRun run(const std::string& args) {
  const std::string cmd = std::string(CONTEGO_BIN) + " " + args + " 2>&1";
  CliRun r;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  std::array<char, 4096> buf{};
  size_t n = 0;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string data(const std::string& name) { return std::string(SCHED_DATA_DIR) + "/" + name; }

const nlohmann::json* find_task(const nlohmann::json& doc, const std::string& name) {
  for (const auto& t : doc["tasks"]) {
    if (t["name"] == name) return &t;
  }
  return nullptr;
}

// The issue's example from the command line: C^TEE 1.5, 3, 3.5 ms;
// B 1, 0.5, 0 ms; R^TEE 2.5, 6.5, 15.5 ms; all schedulable.
TEST(SchedCliTest, IssueExampleJson) {
  const CliRun r = run("sched " + data("issue_example.csv") + " --overhead 0.5ms --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_TRUE(doc["schedulable"].get<bool>());
  struct Want {
    const char* name;
    int64_t c_tee, blocking, response;
  };
  for (const Want& w :
       {Want{"t1", 1'500'000, 1'000'000, 2'500'000}, Want{"t2", 3'000'000, 500'000, 6'500'000},
        Want{"t3", 3'500'000, 0, 15'500'000}}) {
    const nlohmann::json* t = find_task(doc, w.name);
    ASSERT_NE(t, nullptr) << w.name;
    EXPECT_EQ((*t)["c_tee_ns"], w.c_tee) << w.name;
    EXPECT_EQ((*t)["blocking_ns"], w.blocking) << w.name;
    EXPECT_EQ((*t)["response_ns"], w.response) << w.name;
    EXPECT_TRUE((*t)["schedulable"].get<bool>()) << w.name;
  }
  EXPECT_EQ(doc["max_overhead_ns"], 800'000);
}

TEST(SchedCliTest, TextTableAndVerdict) {
  const CliRun r = run("sched " + data("issue_example.csv") + " --overhead 500us");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("15.5ms"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("schedulable: every task meets its deadline"), std::string::npos);
  EXPECT_NE(r.out.find("checking may cost up to 800us per command"), std::string::npos) << r.out;
}

// At 2 ms per command t1 misses (C^TEE 3 + B 4 = 7 > 4): exit status 1.
TEST(SchedCliTest, UnschedulableExitsOne) {
  const CliRun r = run("sched " + data("issue_example.csv") + " --overhead 2ms --json");
  ASSERT_EQ(r.status, 1) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_FALSE(doc["schedulable"].get<bool>());
  const nlohmann::json* t1 = find_task(doc, "t1");
  ASSERT_NE(t1, nullptr);
  EXPECT_TRUE((*t1)["response_ns"].is_null());
  EXPECT_EQ((*t1)["response_exceeds_ns"], 7'000'000);
}

TEST(SchedCliTest, MeasuredOverheadFromBenchFile) {
  const CliRun r = run("sched " + data("issue_example.csv") + " --overhead-from " +
                       data("measured_overhead.json") + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_EQ(doc["tasks"][0]["overhead_ns"], 500'000);
  EXPECT_NE(doc["overhead_source"].get<std::string>().find("measured"), std::string::npos);
}

// The default statistic of a file with several is p99.9; the worst is shown
// beside it; --stat chooses another.
TEST(SchedCliTest, MeasuredOverheadStatistic) {
  CliRun r = run("sched " + data("issue_example.csv") + " --overhead-from " +
                 data("measured_statistics.json") + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_EQ(doc["tasks"][0]["overhead_ns"], 300'000);
  EXPECT_EQ(doc["overhead_statistic"], "p999");
  EXPECT_EQ(doc["overhead_worst_ns"], 2'000'000);
  r = run("sched " + data("issue_example.csv") + " --overhead-from " +
          data("measured_statistics.json") + " --stat max");
  EXPECT_EQ(r.status, 1) << r.out;  // 2 ms per command: t1 misses
  EXPECT_NE(r.out.find("C^o from measured max (worst 2ms)"), std::string::npos) << r.out;
  r = run("sched " + data("issue_example.csv") + " --overhead-from " +
          data("measured_statistics.json") + " --stat p42");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("no statistic 'p42' (the file has max, median, p99, p999)"),
            std::string::npos)
      << r.out;
  r = run("sched " + data("issue_example.csv") + " --stat p99");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("give the file"), std::string::npos) << r.out;
}

// One result line per set, errors named by line, the stream goes on; the
// exit status says a set was bad.
TEST(SchedCliTest, BatchStream) {
  CliRun r = run("sched --batch " + data("stream.jsonl"));
  EXPECT_EQ(r.status, 2) << r.out;
  std::vector<nlohmann::json> lines;  // stdout's; stderr's lines do not start with '{'
  size_t start = 0;
  while (start < r.out.size()) {
    const size_t end = r.out.find('\n', start);
    if (r.out[start] == '{')
      lines.push_back(nlohmann::json::parse(r.out.substr(start, end - start)));
    start = end + 1;
  }
  EXPECT_NE(r.out.find("4 task sets, 1 unschedulable, 1 bad"), std::string::npos) << r.out;
  ASSERT_EQ(lines.size(), 4u) << r.out;
  EXPECT_TRUE(lines[0]["schedulable"].get<bool>());
  EXPECT_FALSE(lines[1]["schedulable"].get<bool>());
  EXPECT_EQ(lines[2]["line"], 3);
  EXPECT_NE(lines[2]["error"].get<std::string>().find("stream.jsonl:3"), std::string::npos);
  EXPECT_EQ(lines[3]["line"], 5);
  EXPECT_EQ(lines[3]["max_overhead_ns"], 800'000);  // the issue's example
  EXPECT_EQ(lines[3]["tasks"][2]["response_ns"], 15'500'000);
  // Without the bad line: 1 (a set can miss); stdin works as well.
  r = run("sched --batch - --no-sensitivity < " + data("stream_ok.jsonl"));
  EXPECT_EQ(r.status, 1) << r.out;
}

TEST(SchedCliTest, BadInputsExitTwoWithAClearMessage) {
  CliRun r = run("sched " + data("deadline_beyond_period.csv") + " --overhead 0.5ms");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("task 'slow': deadline 15ms exceeds period 10ms"), std::string::npos)
      << r.out;
  r = run("sched " + data("issue_example.csv") + " --overhead 0.5");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("--overhead: invalid duration '0.5': missing unit"), std::string::npos)
      << r.out;
  r = run("sched " + data("no_such_file.csv"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("cannot open"), std::string::npos) << r.out;
}

// Priorities rewritten by deadline-monotonic: shortest deadline on top.
TEST(SchedCliTest, AssignDeadlineMonotonic) {
  const CliRun r =
      run("sched " + data("issue_example.csv") + " --overhead 0.5ms --assign dm --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  EXPECT_EQ(doc["assignment"], "dm");
  EXPECT_GT((*find_task(doc, "t1"))["priority"], (*find_task(doc, "t3"))["priority"]);
}

#ifdef CONTEGO_HAVE_POLICY
// The rover policy's task model, by hand at C^o = 50 us: follower C = 40 ms,
// N = 3, alone: C^TEE = R = 40 + 3 * 0.05 = 40.15 ms <= 200 ms; it tolerates
// C^o up to (200 - 40) / 3 = 53.333333 ms.
TEST(SchedCliTest, TaskModelFromPolicy) {
  const CliRun r = run("sched " + std::string(POLICY_DIR) + "/rover.policy --overhead 50us --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(r.out);
  const nlohmann::json* f = find_task(doc, "follower");
  ASSERT_NE(f, nullptr) << r.out;
  EXPECT_EQ((*f)["response_ns"], 40'150'000);
  EXPECT_EQ(doc["max_overhead_ns"], 20'000'000);  // (100 ms - 40 ms) / 3
}
#endif

}  // namespace
