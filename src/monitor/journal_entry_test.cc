// The audit log's entries for the journal (journal_entry.h): a decision that
// is not `allow` with its names and a priority by verdict, events by kind,
// the log's own failure as an error, and the limits that keep a flood out.
#include "monitor/journal_entry.h"

#include <gtest/gtest.h>
#include <string>
#include <vector>

#include "base/test_temp.h"
#include "monitor/audit_log.h"
#include "monitor/test_audit_record.h"

namespace contego::monitor {
namespace {

struct Captured {
  Priority priority;
  std::string kind, message, task, device, command, rule, verdict, reason;
};

class JournalEntries : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_file("contego-journal", &path));
  }
  AuditOptions options() {
    AuditOptions o;
    o.journal = [this](const JournalEntry& e) {
      got.push_back({e.priority, std::string(e.kind), e.message, e.task, e.device, e.command,
                     e.rule, e.verdict, e.reason});
    };
    return o;
  }
  core::AuditRecord record(core::Decision d) {
    return testing::decision_record(1, d, 0x40, std::span<const uint8_t>(bytes, 2));
  }
  std::string path;
  std::vector<Captured> got;
  const uint8_t bytes[2] = {0x06, 0x01};
};

TEST_F(JournalEntries, ADecisionNotAllowedCarriesItsNamesAndAPriorityByVerdict) {
  AuditLog log;
  ASSERT_TRUE(log.open(path, options()).ok());
  EXPECT_TRUE(
      log.decision(record(core::Decision::kAllow), RecordNames{"gripper", "arm", "led", nullptr}));
  EXPECT_TRUE(got.empty()) << "an allowed command is not the operator's business";
  EXPECT_TRUE(log.decision(record(core::Decision::kIgnore),
                           RecordNames{"gripper", "arm", "led", "gripper_rate"}));
  EXPECT_TRUE(log.decision(record(core::Decision::kFailsafe),
                           RecordNames{"gripper", "arm", "led", "line_safe"}));
  EXPECT_TRUE(
      log.decision(record(core::Decision::kIgnore), RecordNames{"gripper", "arm", "led", "latch"}));
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0].kind, "decision");
  EXPECT_EQ(got[0].priority, Priority::kNotice);
  EXPECT_EQ(got[0].task, "gripper");
  EXPECT_EQ(got[0].device, "arm");
  EXPECT_EQ(got[0].command, "led");
  EXPECT_EQ(got[0].rule, "gripper_rate");
  EXPECT_EQ(got[0].verdict, "ignore");
  EXPECT_NE(got[0].message.find("contego: task gripper: ignore of command led on device arm"),
            std::string::npos)
      << got[0].message;
  EXPECT_EQ(got[1].priority, Priority::kWarning) << "a substituted command is a warning";
  EXPECT_EQ(got[1].verdict, "failsafe");
  EXPECT_EQ(got[2].kind, "latch");
  EXPECT_EQ(got[2].priority, Priority::kWarning);
}

TEST_F(JournalEntries, EventsGoByKindAndAFloodIsCountedNotSent) {
  AuditLog log;
  ASSERT_TRUE(log.open(path, options()).ok());
  EXPECT_TRUE(log.event("fault", "safe state of device 0 failed: errno 5"));
  EXPECT_TRUE(log.event("safe-state", "start"));
  EXPECT_TRUE(log.event("start", "policy x"));
  EXPECT_TRUE(log.event("shadow", "read back"));
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0].priority, Priority::kError);
  EXPECT_EQ(got[0].message, "contego: fault: safe state of device 0 failed: errno 5");
  EXPECT_EQ(got[1].priority, Priority::kWarning);
  EXPECT_EQ(got[2].priority, Priority::kNotice);
  EXPECT_EQ(got[3].priority, Priority::kInfo);
  got.clear();
  for (int i = 0; i < 100; ++i) EXPECT_TRUE(log.event("malformed", "flood")) << "recorded";
  EXPECT_LE(got.size(), 20u + 16u) << "at most 20 a second reach the journal";
  EXPECT_GE(got.size(), 16u);
}

TEST_F(JournalEntries, TheLogsOwnFailureIsAnError) {
  AuditLog log;
  AuditOptions o = options();
  o.allow_unsafe = true;
  ASSERT_TRUE(log.open("/dev/full", o).ok());
  got.clear();
  EXPECT_FALSE(log.decision(record(core::Decision::kIgnore), "t"));
  bool failure = false;
  for (const Captured& c : got) {
    if (c.kind != "audit-failure") continue;
    failure = true;
    EXPECT_EQ(c.priority, Priority::kError);
    EXPECT_NE(c.message.find("AUDIT LOG FAILURE"), std::string::npos) << c.message;
  }
  EXPECT_TRUE(failure);
}

}  // namespace
}  // namespace contego::monitor
