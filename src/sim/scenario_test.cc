#include "sim/scenario.h"

#include <gtest/gtest.h>

namespace contego::sim {
namespace {

Result<Scenario> parse(const std::string& text) { return parse_scenario(text, "s.scn", "dir"); }

TEST(ScenarioTest, ParsesEveryKeyword) {
  auto sc = parse(
      "# comment\n"
      "title Rover under spoofing\n"
      "platform rover\n"
      "policy ../policies/rover.policy\n"
      "duration 20s\nstep 1ms\ntrace 50ms\nseed 7\n"
      "set period 200ms\n"
      "attack dos from 5s to 9s count=12  # trailing comment\n");
  ASSERT_TRUE(sc.ok()) << sc.error();
  EXPECT_EQ(sc->title, "Rover under spoofing");
  EXPECT_EQ(sc->platform, "rover");
  EXPECT_EQ(sc->policy_path, "dir/../policies/rover.policy");
  EXPECT_EQ(sc->duration_us, 20'000'000u);
  EXPECT_EQ(sc->seed, 7u);
  ASSERT_EQ(sc->attacks.size(), 1u);
  EXPECT_EQ(sc->attacks[0].start_us, 5'000'000u);
  EXPECT_EQ(sc->attacks[0].param_int("count", 0), 12);
  EXPECT_EQ(sc->settings.at("period"), "200ms");
}

TEST(ScenarioTest, ErrorsNameTheFileAndLine) {
  auto sc = parse("platform rover\npolicy p\nduration 10\n");
  ASSERT_FALSE(sc.ok());
  EXPECT_NE(sc.error().find("s.scn:3:"), std::string::npos) << sc.error();
  EXPECT_NE(sc.error().find("unit"), std::string::npos) << sc.error();
}

TEST(ScenarioTest, RefusesUnknownPlatformKeywordAndAttack) {
  EXPECT_NE(parse("platform boat\n").error().find("unknown platform 'boat'"), std::string::npos);
  EXPECT_NE(parse("platform rover\nfly high\n").error().find("s.scn:2: unknown keyword 'fly'"),
            std::string::npos);
  auto bad = parse("platform rover\npolicy p\nattack teleport from 1s to 2s\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("unknown rover attack 'teleport'"), std::string::npos) << bad.error();
}

TEST(ScenarioTest, RefusesWindowsOutsideTheRun) {
  auto sc = parse("platform rover\npolicy p\nduration 10s\nattack spoof from 5s to 12s\n");
  ASSERT_FALSE(sc.ok());
  EXPECT_NE(sc.error().find("ends after"), std::string::npos) << sc.error();
  auto back = parse("platform rover\npolicy p\nattack spoof from 5s to 4s\n");
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.error().find("s.scn:3:"), std::string::npos) << back.error();
}

TEST(ScenarioTest, RefusesRepeatedKeywordsAndMissingLines) {
  EXPECT_NE(parse("platform rover\nplatform arm\n").error().find("given twice"), std::string::npos);
  EXPECT_NE(parse("platform rover\nattack spoof from 1s to 2s\n").error().find("missing 'policy'"),
            std::string::npos);
}

TEST(ScenarioTest, RefusesRunsTooLongToTrace) {
  // 10^14 s ran for half a minute and died allocating its trace.
  auto huge =
      parse("platform rover\npolicy p\nduration 100000000000000s\nattack spoof from 1s to 2s\n");
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.error().find("trace rows"), std::string::npos) << huge.error();
  auto steps = parse(
      "platform rover\npolicy p\nduration 300h\nstep 1ms\ntrace 10s\n"
      "attack spoof from 1s to 2s\n");
  ASSERT_FALSE(steps.ok());
  EXPECT_NE(steps.error().find("steps"), std::string::npos) << steps.error();
}

}  // namespace
}  // namespace contego::sim
