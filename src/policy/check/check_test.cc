#include "policy/check/check.h"

#include <gtest/gtest.h>

#include "policy/lex/lex.h"
#include "policy/parse/parse.h"

namespace contego::policy {
namespace {

struct Checked {
  CheckedPolicy policy;
  std::vector<Diagnostic> diags;
  std::vector<std::string> ids() const {
    std::vector<std::string> out;
    for (const auto& d : diags) out.push_back(d.id);
    return out;
  }
};

Checked run(const std::string& text) {
  SourceBuffer src("t.policy", text);
  DiagnosticEmitter d(src);
  const ast::File f = parse(lex(src, d), d);
  Checked c;
  c.policy = check(f, src, d, [](std::string_view n) { return devices::find_builtin_profile(n); });
  c.diags = d.take();
  return c;
}

constexpr const char* kBase = R"(
device gopigo : gopigo2 at i2c-1 0x08
device line : line_follower at i2c-1 0x06
task t { period 100ms; wcet 1ms; actuations 2 }
allow t -> gopigo
)";

TEST(Check, DurationWhereANumberIsExpectedIsAUnitError) {
  const Checked c = run(std::string(kBase) + "task u { period 100ms; wcet 1ms; priority 2ms }\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"E0401"}));
}

TEST(Check, ComparingADurationWithANumberIsRefused) {
  const Checked c =
      run(std::string(kBase) + "invariant A on gopigo: require since_last() > 5 else ignore\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"E0402"}));
}

TEST(Check, BooleanConditionIsRequired) {
  const Checked c =
      run(std::string(kBase) + "invariant A on gopigo.set_left_speed: require speed else ignore\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"E0401"}));
}

TEST(Check, IntervalAnalysisFindsImpossibleComparisons) {
  // raw0 is a 10-bit reading: it can never exceed 2000.
  const Checked c = run(std::string(kBase) +
                        "invariant A on gopigo: when line.raw0 > 2000 expect stop() else ignore\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"W0704", "W0703"}));
}

TEST(Check, LinePositionIsBoundedByItsCalibration) {
  const Checked c = run(std::string(kBase) + R"(
signal pos = line_position(line.raw, white=[0,0,0,0,0], black=[1023,1023,1023,1023,1023],
                           weights=[-100,-50,0,50,100])
invariant A on gopigo: when pos < 0 expect stop() else ignore
)");
  EXPECT_TRUE(c.diags.empty()) << c.diags[0].rendered;
  ASSERT_EQ(c.policy.signals.size(), 6u);  // five raw + pos
  EXPECT_EQ(c.policy.signals[5].lo, -15000);
  EXPECT_EQ(c.policy.signals[5].hi, 15000);
}

TEST(Check, RateAboveActuationsWarns) {
  const Checked c = run(std::string(kBase) + "limit t -> gopigo 5 per job else ignore\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"W0702"}));
}

TEST(Check, ExpectMaskIsTheExpectedGroups) {
  const Checked c = run(std::string(kBase) +
                        "invariant A on gopigo: when 1 > 0 expect set_left_speed(5) else ignore\n");
  ASSERT_EQ(c.policy.invariants.size(), 1u);
  EXPECT_EQ(c.policy.invariants[0].commands.size(), 1u);  // only set_left_speed is in its group
}

}  // namespace
}  // namespace contego::policy
