#include "monitor/audit_log.h"

#include <sched.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include "base/test_temp.h"
#include "monitor/audit_explain.h"
#include "monitor/test_audit_record.h"

namespace contego::monitor {
namespace {

class AuditChain : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_file("contego-audit-chain", &path));
  }
  void TearDown() override { unlink(path.c_str()); }

  void write_some(int decisions) {
    AuditLog log;
    ASSERT_TRUE(log.open(path).ok());
    log.event("start", "test");
    const uint8_t bytes[] = {0x01, 0x46, 0x64, 0x00, 0x00};
    for (int i = 0; i < decisions; ++i) {
      const auto decision = i % 3 == 0 ? core::Decision::kReject : core::Decision::kAllow;
      log.decision(testing::decision_record(static_cast<uint32_t>(i), decision, 0x08, bytes),
                   "follower");
    }
  }
  std::vector<std::string> lines() {
    std::ifstream in(path);
    std::vector<std::string> v;
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
  }
  void put(const std::vector<std::string>& v) {
    std::ofstream out(path, std::ios::trunc);
    for (const auto& l : v) out << l << '\n';
  }
  AuditCheck verify() {
    std::ifstream in(path);
    return verify_audit(in);
  }
  std::string path;
};

// The decision line byte for byte, every optional key present: the format
// readers and the hash chain depend on (docs/audit-format.md). The first
// line's "prev" is the genesis hash; t_us is the record's own.
TEST_F(AuditChain, DecisionLineIsWrittenByteForByte) {
  {
    AuditLog log;
    ASSERT_TRUE(log.open(path).ok());
    const uint8_t bytes[] = {0x1a, 0x00, 0xff, 0xa4, 0x01};
    const uint8_t substitute[] = {0x1a, 0x20};
    core::AuditRecord r{};
    r.job = 4294967295u;
    r.task = 3;
    r.device = 1;
    r.command = 65535;
    r.rule = 7;
    r.rule_kind = core::RuleKind::kInvariant;
    r.decision = core::Decision::kFailsafe;
    r.reason = core::Reason::kInvariantViolated;
    r.index = 255;
    r.fields[0] = -2147483647 - 1;
    r.fields[1] = 0;
    r.fields[2] = 2147483647;
    r.field_count = 3;
    r.bus = 250;
    r.addr = 0x3ff;
    r.original = bytes;
    r.original_len = sizeof bytes;
    r.substitute = substitute;
    r.substitute_len = sizeof substitute;
    RecordNames names{"t\"a\\sk\n\x01\xc3\xa9\xff", "arm", "LED", "grip_sequence"};
    names.pid = 4242;
    names.uid = 0;
    names.mono_us = 123456789;
    names.t_us = 1700000000000001;
    ASSERT_TRUE(log.decision(r, names));
  }
  const std::vector<std::string> l = lines();
  ASSERT_EQ(l.size(), 1u);
  EXPECT_EQ(l[0],
            "{\"addr\":1023,\"bus\":250,\"bytes\":\"1a 00 ff a4 01\",\"command\":65535,"
            "\"command_name\":\"LED\",\"decision\":\"failsafe\",\"device\":1,\"device_name\":"
            "\"arm\",\"fields\":[-2147483648,0,2147483647],\"index\":255,\"job\":4294967295,"
            "\"kind\":\"decision\",\"mono_us\":123456789,\"pid\":4242,\"reason\":20,"
            "\"reason_name\":\"invariant-violated\",\"rule\":7,\"rule_kind\":3,\"rule_name\":"
            "\"grip_sequence\",\"substitute\":\"1a 20\",\"t_us\":1700000000000001,\"task\":3,"
            "\"task_name\":\"t\\\"a\\\\sk\\n\\u0001\xc3\xa9\\ufffd\",\"uid\":0,\"prev\":\"" +
                std::string(kAuditGenesis) + "\"}");
  EXPECT_TRUE(verify().ok) << verify().error;
}

// A client's bytes reach the log (a task name in a refused hello, say): they
// must not be able to stop the monitor, and the chain must still verify.
TEST_F(AuditChain, DecisionRecordsCarryNamesAndExplainInWords) {
  {
    AuditLog log;
    ASSERT_TRUE(log.open(path).ok());
    NameTable names;
    names.tasks = {"follower"};
    names.devices = {"gopigo"};
    names.commands = {"fwd", "set_left_speed"};
    names.invariants = {"INV3"};
    const uint8_t bytes[] = {0x01, 0x46, 0xFF, 0x00, 0x00};
    const uint8_t sub[] = {0x01, 0x46, 0x50, 0x00, 0x00};
    core::AuditRecord r = testing::decision_record(7, core::Decision::kFailsafe, 0x08, bytes, sub);
    r.command = 1;
    r.reason = core::Reason::kInvariantViolated;
    r.rule_kind = core::RuleKind::kInvariant;
    r.fields[0] = 255;
    r.field_count = 1;
    r.bus = 1;
    ASSERT_TRUE(log.decision(r, names.of(r)));
  }
  const auto v = lines();
  ASSERT_EQ(v.size(), 1u);
  const auto j = nlohmann::json::parse(v[0]);
  EXPECT_EQ(j["task_name"], "follower");
  EXPECT_EQ(j["device_name"], "gopigo");
  EXPECT_EQ(j["command_name"], "set_left_speed");
  EXPECT_EQ(j["rule_name"], "INV3");
  EXPECT_EQ(j["reason_name"], "invariant-violated");
  EXPECT_EQ(j["decision"], "failsafe");
  EXPECT_TRUE(verify().ok);
  const std::string words = explain_audit_line(v[0]);
  EXPECT_NE(words.find("follower (job 7) -> gopigo at i2c-1 0x08: set_left_speed(255) REPLACED"),
            std::string::npos)
      << words;
  EXPECT_NE(words.find("by invariant INV3 (invariant-violated); wrote [01 46 50 00 00] instead"),
            std::string::npos)
      << words;
  EXPECT_EQ(explain_audit_line(""), "");
}

TEST_F(AuditChain, InvalidUtf8FromAClientIsWrittenNotThrown) {
  {
    AuditLog log;
    ASSERT_TRUE(log.open(path).ok());
    log.event("malformed", std::string("no task named '\xff\xfe\x80'"));
    core::AuditRecord r{};
    log.decision(r, "\xc3");
  }
  const AuditCheck c = verify();
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.lines, 2u);
}

TEST_F(AuditChain, AFreshLogVerifiesAndIsSummarised) {
  write_some(6);
  const AuditCheck c = verify();
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.lines, 7u);
  EXPECT_EQ(c.summary.decisions, 6u);
  EXPECT_EQ(c.summary.by_decision.at("reject"), 2u);
  EXPECT_EQ(c.summary.by_decision.at("allow"), 4u);
  EXPECT_EQ(c.summary.by_task.at("follower"), 6u);
  EXPECT_EQ(c.summary.events.at("start"), 1u);
  EXPECT_TRUE(c.summary.starts_at_genesis);
  EXPECT_EQ(c.summary.last_hash.size(), 64u);
}

// An idle log wakes no one: its grower thread waits for the writer's
// notification, not on a timer (it used to wake every 20 ms).
TEST_F(AuditChain, AnIdleLogsGrowerSleeps) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  log.event("start", "test");
  auto grower_switches = [] {
    for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
      std::ifstream comm(task.path() / "comm");
      std::string name;
      std::getline(comm, name);
      if (name != AuditLog::kGrowerThreadName) continue;
      std::ifstream status(task.path() / "status");
      for (std::string line; std::getline(status, line);) {
        if (line.rfind("voluntary_ctxt_switches:", 0) == 0) return std::stol(line.substr(24));
      }
    }
    return -1L;
  };
  usleep(100000);  // let it finish what the open asked of it
  const long before = grower_switches();
  ASSERT_GE(before, 0) << "no thread named " << AuditLog::kGrowerThreadName;
  usleep(600000);
  EXPECT_LE(grower_switches() - before, 1);
}

// The grower's page work never takes the CPU from a thread that checks
// commands: as a batch thread it does not preempt the writer that wakes it
// (a woken nice-19 thread does under EEVDF), at nice 19 it has the least
// share of a busy CPU.
TEST_F(AuditChain, TheGrowerIsABatchThreadAtNice19) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  log.event("start", "test");
  usleep(100000);  // the thread sets its own policy when it starts
  pid_t grower = -1;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    std::getline(comm, name);
    if (name == AuditLog::kGrowerThreadName) grower = std::stoi(task.path().filename().string());
  }
  ASSERT_GT(grower, 0) << "no thread named " << AuditLog::kGrowerThreadName;
  EXPECT_EQ(sched_getscheduler(grower), SCHED_BATCH);
  errno = 0;
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(grower)), 19);
  EXPECT_EQ(errno, 0);
}

TEST_F(AuditChain, ReopeningContinuesTheChain) {
  write_some(2);
  write_some(2);  // a restarted monitor appends
  const AuditCheck c = verify();
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.lines, 6u);
}

TEST_F(AuditChain, AnEditedDecisionBreaksTheChainAtTheNextLine) {
  write_some(4);
  auto v = lines();
  const size_t pos = v[1].find("\"decision\":\"reject\"");
  ASSERT_NE(pos, std::string::npos) << v[1];
  v[1].replace(pos, 19, "\"decision\":\"allow\"");  // hide a refusal
  put(v);
  const AuditCheck c = verify();
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.bad_line, 3u);
  EXPECT_NE(c.error.find("line 3"), std::string::npos) << c.error;
}

TEST_F(AuditChain, ARemovedLineBreaksTheChain) {
  write_some(4);
  auto v = lines();
  v.erase(v.begin() + 2);
  put(v);
  const AuditCheck c = verify();
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.bad_line, 3u);
}

TEST_F(AuditChain, ALineWithoutAHashIsRefused) {
  write_some(1);
  auto v = lines();
  v.push_back("{\"kind\":\"decision\",\"decision\":\"allow\"}");
  put(v);
  const AuditCheck c = verify();
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.error.find("no \"prev\""), std::string::npos) << c.error;
}

// "Lose nothing already recorded": a record is in the file before the
// decision acts. The child acts (a byte on a pipe) right after each record;
// once the parent has seen N acts, SIGKILL must leave N verified decisions.
TEST_F(AuditChain, AKilledWriterLosesNoRecordWhoseDecisionActed) {
  int acted[2];
  ASSERT_EQ(pipe(acted), 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    close(acted[0]);
    AuditLog log;
    if (!log.open(path).ok()) _exit(1);
    const uint8_t bytes[] = {0x01, 0x46, 0x50, 0x00, 0x00};
    for (uint32_t i = 0;; ++i) {
      log.decision(testing::decision_record(i, core::Decision::kAllow, 0x08, bytes), "follower");
      if (write(acted[1], "x", 1) != 1) _exit(1);  // the decision acts
    }
  }
  close(acted[1]);
  char c;
  for (int i = 0; i < 300; ++i) ASSERT_EQ(read(acted[0], &c, 1), 1);
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  uint64_t total = 300;  // acts the child managed before the kill landed
  while (read(acted[0], &c, 1) == 1) ++total;
  close(acted[0]);
  const AuditCheck check = verify();
  ASSERT_TRUE(check.ok) << check.error;  // a record torn by the kill is reported, not refused
  EXPECT_GE(check.summary.decisions, total);
  // A restarted monitor continues after the last record (not after the zero
  // padding a mapped log may leave) and the chain still verifies.
  write_some(1);
  const AuditCheck again = verify();
  ASSERT_TRUE(again.ok) << again.error;
  EXPECT_EQ(again.summary.decisions, check.summary.decisions + 1);
  std::ifstream in(path, std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(all.find('\0'), std::string::npos);  // a clean close leaves no padding
  EXPECT_EQ(all.back(), '\n');
}

// A record cut off by a kill (a partial line, then the zero padding) is
// dropped when the log is reopened: the chain continues from the last
// complete line.
TEST_F(AuditChain, ARecordTornByAKillIsReportedAndNotContinuedFrom) {
  write_some(2);
  {
    std::ofstream out(path, std::ios::app | std::ios::binary);
    out << "{\"addr\":8,\"bus\":1,\"byt" << std::string(100, '\0');
  }
  const AuditCheck torn = verify();
  ASSERT_TRUE(torn.ok) << torn.error;
  EXPECT_TRUE(torn.summary.torn_tail);
  EXPECT_EQ(torn.summary.lines, 3u);
  write_some(1);
  const AuditCheck again = verify();
  ASSERT_TRUE(again.ok) << again.error;
  EXPECT_FALSE(again.summary.torn_tail);
  EXPECT_EQ(again.summary.lines, 5u);
}

// A reader of a running monitor's log sees the records and then zeros.
TEST_F(AuditChain, AnOpenLogVerifiesWhileItIsBeingWritten) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  log.event("start", "test");
  log.event("peer", "pid 1");
  const AuditCheck c = verify();
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.lines, 2u);
  // The file was extended ahead of the writer (records are mapped, not written).
  struct stat st {};
  ASSERT_EQ(stat(path.c_str(), &st), 0);
  EXPECT_GE(st.st_size, 64 * 1024);
}

// More than one mapping's worth of records: the log is remapped further on.
TEST_F(AuditChain, ALogLargerThanOneMappingVerifies) {
  write_some(5000);  // about 1.4 MB
  const AuditCheck c = verify();
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.decisions, 5000u);
}

// The lines are formatted by hand (no JSON library on the decision path):
// every field must still come out as JSON, whatever an event quotes.
TEST_F(AuditChain, HandFormattedLinesAreJsonWithEveryField) {
  {
    AuditLog log;
    ASSERT_TRUE(log.open(path).ok());
    log.event("malformed", "quote \" back\\slash\nnew\x01line \xff\xfe");
    const uint8_t bytes[] = {0x1A, 0x00, 0xFF};
    const uint8_t sub[] = {0x1A, 0x00, 0x00};
    core::AuditRecord r = testing::decision_record(77, core::Decision::kFailsafe, 0x40, bytes, sub);
    r.task = 3;
    r.device = 2;
    r.command = 0xFFFF;
    r.rule = 5;
    r.index = 4;
    r.field_count = 2;
    r.fields[0] = -12;
    r.fields[1] = 4095;
    r.bus = 1;
    log.decision(r, "grip\"per");
  }
  const auto v = lines();
  ASSERT_EQ(v.size(), 2u);
  const auto e = nlohmann::json::parse(v[0]);
  EXPECT_EQ(e["kind"], "malformed");
  EXPECT_EQ(e["detail"].get<std::string>().substr(0, 27), "quote \" back\\slash\nnew\x01line");
  const auto d = nlohmann::json::parse(v[1]);
  EXPECT_EQ(d["kind"], "decision");
  EXPECT_EQ(d["task"], 3);
  EXPECT_EQ(d["task_name"], "grip\"per");
  EXPECT_EQ(d["job"], 77);
  EXPECT_EQ(d["device"], 2);
  EXPECT_EQ(d["command"], 0xFFFF);
  EXPECT_EQ(d["rule"], 5);
  EXPECT_EQ(d["index"], 4);
  EXPECT_EQ(d["decision"], "failsafe");
  EXPECT_EQ(d["fields"], nlohmann::json::array({-12, 4095}));
  EXPECT_EQ(d["bus"], 1);
  EXPECT_EQ(d["addr"], 0x40);
  EXPECT_EQ(d["bytes"], "1a 00 ff");
  EXPECT_EQ(d["substitute"], "1a 00 00");
  EXPECT_GT(d["t_us"].get<uint64_t>(), 0u);
  const AuditCheck c = verify();
  EXPECT_TRUE(c.ok) << c.error;
}

}  // namespace
}  // namespace contego::monitor
