#include "monitor/drop_report.h"

#include <cstdio>
#include <gtest/gtest.h>
#include <string>

#include "monitor/audit_log.h"

namespace contego::monitor {
namespace {

std::string contents(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string text;
  for (int c = std::fgetc(f); c != EOF; c = std::fgetc(f)) text += static_cast<char>(c);
  return text;
}

core::AuditRecord record(uint16_t task, core::Decision decision) {
  core::AuditRecord r{};
  r.task = task;
  r.decision = decision;
  r.reason =
      decision == core::Decision::kAllow ? core::Reason::kAllowed : core::Reason::kRateExceeded;
  return r;
}

// A dropped command is named on the report at once; more drops of the task
// within the interval are counted into the next line, not printed one by one.
TEST(DropReport, NamesTheFirstDropAndCountsTheRestUntilTheNextLine) {
  std::FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  DropReport report(out, 1'000'000);
  RecordNames names;
  names.task = "follower";
  names.device = "gopigo";
  names.command = "increase_speed";
  names.rule = "follower->gopigo.speed_step";
  report.note(record(0, core::Decision::kAllow), names, 10);
  EXPECT_EQ(contents(out), "");
  report.note(record(0, core::Decision::kIgnore), names, 20);
  report.note(record(0, core::Decision::kIgnore), names, 30);
  report.note(record(0, core::Decision::kReject), names, 40);
  EXPECT_EQ(contents(out),
            "contego: task follower: increase_speed to gopigo ignored (the program was told it "
            "succeeded): follower->gopigo.speed_step, rate-exceeded\n");
  report.note(record(0, core::Decision::kFailsafe), names, 1'000'030);
  const std::string text = contents(out);
  EXPECT_NE(text.find("replaced by its fail-safe: follower->gopigo.speed_step, rate-exceeded; 2 "
                      "more dropped since the last line\n"),
            std::string::npos)
      << text;
  EXPECT_EQ(report.summary(0), "1 allowed, 2 ignored, 1 substituted, 1 refused");
  core::AuditRecord staged = record(0, core::Decision::kAllow);
  staged.reason = core::Reason::kStaged;
  report.note(staged, names, 1'000'040);
  EXPECT_EQ(report.summary(0),
            "2 allowed (1 staged: held until their group's last register), 2 ignored, "
            "1 substituted, 1 refused");
  EXPECT_EQ(report.counts(0).dropped(), 4u);
  EXPECT_EQ(report.counts(1).dropped(), 0u);  // counted per task
  std::fclose(out);
}

TEST(DropReport, WithNoOutputItOnlyCounts) {
  DropReport report(nullptr);
  report.note(record(3, core::Decision::kIgnore), RecordNames{}, 1);
  EXPECT_EQ(report.counts(3).ignored, 1u);
}

}  // namespace
}  // namespace contego::monitor
