// The learn layer: traces read back from audit logs, replay, and the policy
// generator's statistics and suggestions.
#include <fmt/format.h>
#include <fstream>
#include <gtest/gtest.h>

#include "base/test_temp.h"
#include "learn/audit_trace.h"
#include "learn/generate.h"
#include "learn/observe_source.h"
#include "learn/replay.h"
#include "learn/trace_stats.h"
#include "monitor/audit_log.h"
#include "monitor/sha256.h"
#include "policy/compile.h"

namespace contego::learn {
namespace {

// Writes `records` (JSON objects without "prev") as a chained audit log.
std::string write_log(const std::vector<std::string>& records) {
  std::string path;
  test_support::make_temp_file("contego-learn-log", &path);
  std::ofstream out(path);
  std::string prev = monitor::kAuditGenesis;
  for (const std::string& r : records) {
    const std::string line = r.substr(0, r.size() - 1) + ",\"prev\":\"" + prev + "\"}";
    out << line << "\n";
    prev = monitor::sha256_hex(line);
  }
  return path;
}

std::string write_text(const std::string& text) {
  std::string path;
  test_support::make_temp_file("contego-learn-policy", &path);
  std::ofstream(path) << text;
  return path;
}

// The line follower's sample: raw0..raw4, 16 bits each, high byte first.
std::string line_sample(std::array<int, 5> raw) {
  std::string s;
  for (int v : raw) s += fmt::format("{}{:02x} {:02x}", s.empty() ? "" : " ", v >> 8, v & 0xff);
  return s;
}

// A decision of the follower to the GoPiGo2: frame [01 op v 00 00].
std::string frame(uint64_t t_us, uint32_t job, const std::string& command, int op, int value,
                  int64_t tx, std::array<int, 5> raw, const std::string& decision = "allow") {
  return fmt::format(
      R"({{"addr":8,"bus":1,"bytes":"01 {:02x} {:02x} 00 00","command":1,"command_name":"{}",)"
      R"("decision":"{}","device":0,"device_name":"gopigo","fields":[{}],"index":0,"job":{},)"
      R"("kind":"decision","readings":{{"line":{{"age_us":100,"bytes":"{}"}}}},"reason":0,)"
      R"("reason_name":"allowed","rule":65535,"rule_kind":0,"t_us":{},"task":0,)"
      R"("task_name":"follower","tx":{}}})",
      op, value, command, decision,
      command == "fwd" || command == "left" || command == "right" ? "" : std::to_string(value), job,
      line_sample(raw), t_us, tx);
}

constexpr std::array<int, 5> kCentre{767, 815, 1015, 710, 700};
constexpr std::array<int, 5> kLeft{1012, 1013, 859, 710, 700};
constexpr std::array<int, 5> kRight{767, 815, 859, 1003, 1004};

const char* kObservePolicy = R"(device gopigo : gopigo2 at i2c-1 0x08 {
  safe stop()
}
device line : line_follower at i2c-1 0x06 sample 10ms max_age 200ms
task follower {
  period 100ms; deadline 100ms; wcet 40ms; priority 2
}
allow follower -> gopigo
allow follower reads line
)";

TEST(ReadTrace, RefusesADecisionWithoutNamesWithItsLine) {
  const std::string log = write_log(
      {R"({"detail":"x","kind":"start","t_us":1})",
       R"({"addr":8,"bus":1,"bytes":"01 66 00 00 00","command":1,"decision":"allow","device":0,"job":1,"kind":"decision","reason":0,"t_us":2,"task":0})"});
  auto t = read_trace({log});
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find(log + ":2: a decision without `task_name`"), std::string::npos)
      << t.error();
}

TEST(ReadTrace, RefusesABrokenChainWithItsLine) {
  const std::string log = write_log({frame(1000, 1, "fwd", 0x69, 0, 1, kCentre),
                                     frame(2000, 1, "fwd", 0x69, 0, 2, kCentre),
                                     frame(3000, 1, "fwd", 0x69, 0, 3, kCentre)});
  std::ifstream in(log);
  std::string a, b, c;
  std::getline(in, a), std::getline(in, b), std::getline(in, c);
  b.replace(b.find("\"job\":1"), 7, "\"job\":7");  // an edited line breaks the next one's prev
  std::ofstream(log) << a << "\n" << b << "\n" << c << "\n";
  auto t = read_trace({log});
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("line 3"), std::string::npos) << t.error();
}

TEST(ReadTrace, KeepsReadingsTransactionsAndSessionEnds) {
  const std::string log =
      write_log({frame(1000, 1, "set_left_speed", 0x46, 80, 1, kCentre),
                 R"({"detail":"task 0 (follower) exited","kind":"safe-state","t_us":1500})",
                 frame(2000, 1, "fwd", 0x69, 0, 2, kLeft)});
  auto t = read_trace({log});
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_EQ(t->decisions.size(), 2u);
  EXPECT_EQ(t->decisions[0].fields, std::vector<int64_t>{80});
  EXPECT_EQ(t->decisions[1].readings.at("line").bytes[0], 1012 >> 8);
  EXPECT_FALSE(same_transaction(t->decisions[0], t->decisions[1]));
  ASSERT_EQ(t->events.size(), 1u);
  EXPECT_EQ(t->events[0].kind, TraceEvent::Kind::kSessionEnd);
  EXPECT_EQ(t->events[0].name, "follower");
  EXPECT_EQ(t->events[0].before, 1u);
}

TEST(ReadTrace, SkipsRecordsThatFollowAnotherRequestsCheck) {
  // staged-incomplete (29), staging-conflict (24), transfer-dropped (28):
  // their bytes are another request's, so they are no request to replay.
  std::vector<std::string> records{frame(1000, 1, "fwd", 0x69, 0, 1, kCentre)};
  for (const auto& [reason, name] :
       {std::pair{29, "staged-incomplete"}, std::pair{24, "staging-conflict"},
        std::pair{28, "transfer-dropped"}}) {
    std::string r = frame(1500, 1, "fwd", 0x69, 0, 1, kCentre, "ignore");
    const std::string allowed = R"("reason":0,"reason_name":"allowed")";
    r.replace(r.find(allowed), allowed.size(),
              fmt::format(R"("reason":{},"reason_name":"{}")", reason, name));
    records.push_back(r);
  }
  auto t = read_trace({write_log(records)});
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_EQ(t->decisions.size(), 1u);
}

TEST(TraceStats, WindowMaxCountsTheMostInAnyWindowWhateverItsPhase) {
  EXPECT_EQ(window_max({}, 100), 0u);
  EXPECT_EQ(window_max({0, 50, 99, 100, 250}, 100), 3u);
  EXPECT_EQ(window_max({0, 100, 200}, 100), 1u);
  EXPECT_EQ(window_max({10, 60, 140, 150}, 100), 3u);  // [60, 160) holds three
}

TEST(ObserveSource, StatementsKeepTheCommentsBeforeThem) {
  const auto s = split_statements("p",
                                  "# a device\ndevice d : gopigo2 at i2c-1 0x08\n\n"
                                  "task t {\n  period 1s\n}\nallow t -> d  # why\n");
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].keyword, "device");
  EXPECT_EQ(s[0].name, "d");
  EXPECT_EQ(s[0].comments, "# a device\n");
  EXPECT_EQ(s[1].text, "task t {\n  period 1s\n}\n");
  EXPECT_EQ(s[2].text, "allow t -> d  # why\n");
}

// The follower turned by the line: each direction only with its reading.
std::vector<std::string> follower_trace() {
  std::vector<std::string> r;
  int64_t tx = 0;
  uint64_t t = 1000000;
  for (int i = 0; i < 12; ++i, t += 120000) {
    const auto& raw = i % 3 == 0 ? kCentre : i % 3 == 1 ? kLeft : kRight;
    const int speed = i % 3 == 0 ? 80 : i % 3 == 1 ? 85 : 125;
    const auto job = static_cast<uint32_t>((t - 1000000) / 100000 + 1);
    r.push_back(frame(t, job, "set_left_speed", 0x46, speed, ++tx, raw));
    r.push_back(frame(t + 105000, job, "set_right_speed", 0x47, speed, ++tx, raw));
    r.push_back(frame(t + 110000, job,
                      i % 3 == 0   ? "fwd"
                      : i % 3 == 1 ? "right"
                                   : "left",
                      i % 3 == 0   ? 0x69
                      : i % 3 == 1 ? 0x64
                                   : 0x61,
                      0, ++tx, raw));
  }
  return r;
}

TEST(Generate, MeasuresThePeriodAndSuggestsTheReadingThatSeparatesDirections) {
  auto trace = read_trace({write_log(follower_trace())});
  ASSERT_TRUE(trace.ok()) << trace.error();
  GenerateOptions o;
  o.observe_policy = write_text(kObservePolicy);
  o.logs = {"trace.jsonl"};
  auto g = generate_policy(*trace, o);
  ASSERT_TRUE(g.ok()) << g.error();
  EXPECT_NE(g->policy.find("period 110ms; deadline 110ms"), std::string::npos) << g->policy;
  EXPECT_NE(g->policy.find("require speed in 68..137 else ignore"), std::string::npos) << g->policy;
  // fwd only on the line (raw2 dark), right only with the line on the left.
  EXPECT_NE(g->policy.find("# invariant SUGGEST_fwd_raw2 on gopigo.fwd: require line.raw2 in "
                           "1015..1015 else ignore"),
            std::string::npos)
      << g->policy;
  ASSERT_FALSE(g->findings.empty());
  EXPECT_NE(g->findings.back().find("suggested invariant(s)"), std::string::npos);
  // The policy compiles, and so does a suggestion taken in.
  EXPECT_TRUE(policy::compile_source("gen", g->policy).ok);
  std::string taken = g->policy;
  const size_t at = taken.find("# invariant SUGGEST_fwd_raw2");
  taken.erase(at, 2);
  EXPECT_TRUE(policy::compile_source("gen", taken).ok);
}

TEST(Generate, LeavesOutWhatTheTraceNeverUsedAndWhatTheObservePolicyDoesNotName) {
  std::vector<std::string> r = follower_trace();
  std::string foreign = frame(9000000, 90, "fwd", 0x69, 0, 999, kCentre);
  foreign.replace(foreign.find("\"task_name\":\"follower\""), 22, "\"task_name\":\"intruder\"");
  r.push_back(foreign);
  auto trace = read_trace({write_log(r)});
  ASSERT_TRUE(trace.ok()) << trace.error();
  GenerateOptions o;
  o.observe_policy = write_text(std::string(kObservePolicy) +
                                "device arm : pca9685 at i2c-1 0x40 { safe led(5, off=420) }\n");
  auto g = generate_policy(*trace, o);
  ASSERT_TRUE(g.ok()) << g.error();
  EXPECT_NE(g->policy.find("# device arm : pca9685"), std::string::npos) << g->policy;
  EXPECT_EQ(g->policy.find("intruder"), std::string::npos) << g->policy;
  policy::CompileOptions strict;
  strict.strict = true;
  const auto compiled = policy::compile_source("gen", g->policy, strict);
  EXPECT_TRUE(compiled.ok) << (compiled.diagnostics.empty() ? ""
                                                            : compiled.diagnostics[0].rendered);
  std::string all;
  for (const auto& f : g->findings) all += f + "\n";
  EXPECT_NE(all.find("1 decision(s) name a task and 0 a device the observe policy does not "
                     "declare"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("device arm was never commanded"), std::string::npos) << all;
}

TEST(Generate, RefusesATraceWhereNothingActed) {
  auto trace = read_trace({write_log({frame(1000, 1, "fwd", 0x69, 0, 1, kCentre, "ignore")})});
  ASSERT_TRUE(trace.ok()) << trace.error();
  GenerateOptions o;
  o.observe_policy = write_text(kObservePolicy);
  auto g = generate_policy(*trace, o);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("no command of the logs acted"), std::string::npos);
}

TEST(Replay, ReDecidesWithTheLogsReadingsAndJobs) {
  std::vector<std::string> r = {
      frame(1000, 1, "set_left_speed", 0x46, 80, 1, kCentre),
      frame(2000, 1, "set_right_speed", 0x47, 80, 2, kCentre),
      frame(3000, 1, "fwd", 0x69, 0, 3, kCentre),
      frame(4000, 1, "fwd", 0x69, 0, 4, kCentre),                 // a fourth frame in job 1
      frame(200000, 3, "set_left_speed", 0x46, 200, 5, kCentre),  // spoofed
      frame(300000, 4, "right", 0x64, 0, 6, kLeft),
  };
  auto trace = read_trace({write_log(r)});
  ASSERT_TRUE(trace.ok()) << trace.error();
  const auto compiled = policy::compile_file(CONTEGO_SOURCE_DIR "/policies/rover.policy");
  ASSERT_TRUE(compiled.ok);
  auto report = replay(*trace, compiled.model, compiled.image);
  ASSERT_TRUE(report.ok()) << report.error();
  EXPECT_EQ(report->decisions, 6u);
  ASSERT_EQ(report->changes.size(), 2u) << format_replay(*report, "rover");
  EXPECT_EQ(report->changes[0].record->line, 4u);
  EXPECT_EQ(report->changes[0].replayed.decision, "ignore");
  EXPECT_EQ(report->changes[0].replayed.reason, "rate-exceeded");
  EXPECT_EQ(report->changes[1].record->line, 5u);
  EXPECT_EQ(report->changes[1].replayed.decision, "failsafe");
  EXPECT_EQ(report->changes[1].replayed.rule, "INV3");
  const std::string text = format_replay(*report, "rover");
  EXPECT_NE(text.find("2 would change"), std::string::npos) << text;
  EXPECT_NE(text.find("allow -> failsafe: 1"), std::string::npos) << text;
}

}  // namespace
}  // namespace contego::learn
