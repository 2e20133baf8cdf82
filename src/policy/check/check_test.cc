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

TEST(Check, ExpectMaskIsTheExpectedGroups) {
  const Checked c = run(std::string(kBase) +
                        "invariant A on gopigo: when 1 > 0 expect set_left_speed(5) else ignore\n");
  ASSERT_EQ(c.policy.invariants.size(), 1u);
  EXPECT_EQ(c.policy.invariants[0].commands.size(), 1u);  // only set_left_speed is in its group
}

constexpr const char* kPca = R"(
device esc : pca9685 at i2c-1 0x40
task t { period 100ms; wcet 1ms; actuations 2 }
allow t -> esc
)";

// A policy (a base and one more declaration) and the diagnostics the checker
// gives it, by id.
struct Diagnosed {
  const char* name;
  const char* base;
  const char* addition;
  std::vector<std::string> ids;
};

class CheckDiagnoses : public ::testing::TestWithParam<Diagnosed> {};

TEST_P(CheckDiagnoses, ByIdInOrder) {
  const Checked c = run(std::string(GetParam().base) + GetParam().addition);
  EXPECT_EQ(c.ids(), GetParam().ids);
}

const Diagnosed kDiagnosed[] = {
    {"DurationWhereANumberIsExpectedIsAUnitError",
     kBase,
     "task u { period 100ms; wcet 1ms; priority 2ms }\n",
     {"E0401"}},
    {"ComparingADurationWithANumberIsRefused",
     kBase,
     "invariant A on gopigo: require since_last() > 5 else ignore\n",
     {"E0402"}},
    {"BooleanConditionIsRequired",
     kBase,
     "invariant A on gopigo.set_left_speed: require speed else ignore\n",
     {"E0401"}},
    // raw0 is a 10-bit reading: it can never exceed 2000.
    {"IntervalAnalysisFindsImpossibleComparisons",
     kBase,
     "invariant A on gopigo: when line.raw0 > 2000 expect stop() else ignore\n",
     {"W0704", "W0703"}},
    {"RateAboveActuationsWarns", kBase, "limit t -> gopigo 5 per job else ignore\n", {"W0702"}},
    {"LastDefaultMustHaveTheFieldsKind",
     kPca,
     "invariant S on esc.led: require last(off, 1ms) > 0 else ignore\n",
     {"E0401"}},
};

INSTANTIATE_TEST_SUITE_P(Check, CheckDiagnoses, ::testing::ValuesIn(kDiagnosed),
                         [](const auto& p) { return std::string(p.param.name); });

TEST(Check, LastWithoutDefaultAndANonWritingResponseNeverStarts) {
  const Checked c = run(std::string(kPca) +
                        "invariant S on esc.led: require abs(off - last(off)) <= 20 "
                        "else failsafe off = last(off)\n");
  EXPECT_EQ(c.ids(), (std::vector<std::string>{"W0709"}));
  const Checked ignore =
      run(std::string(kPca) + "invariant S on esc.led: require since_last() > 5ms else ignore\n");
  EXPECT_EQ(ignore.ids(), (std::vector<std::string>{"W0709"}));
}

TEST(Check, LastWithADefaultOrAConstantFailsafeStarts) {
  for (const char* rule : {
           "require abs(off - last(off, 307)) <= 20 else failsafe off = last(off, 307)",
           "require since_last(1s) > 5ms else ignore",
           "require abs(off - last(off)) <= 20 else failsafe off = 307",
       }) {
    const Checked c = run(std::string(kPca) + "invariant S on esc.led: " + rule + "\n");
    EXPECT_TRUE(c.diags.empty()) << rule << ": " << c.diags[0].rendered;
    ASSERT_EQ(c.policy.invariants.size(), 1u) << rule;
  }
}

TEST(Check, FailsafeNamingAPulseClearsTheFullOnAndFullOffBits) {
  const Checked c = run(std::string(kPca) +
                        "invariant P on esc.led: require off in 205..410 "
                        "else failsafe off = 307\n");
  ASSERT_EQ(c.policy.invariants.size(), 1u) << (c.diags.empty() ? "" : c.diags[0].rendered);
  const auto& fields = c.policy.invariants[0].response.command->fields;
  std::vector<std::string> named;
  const auto& led = c.policy.devices[0].profile.commands[c.policy.invariants[0].commands[0]];
  for (const FieldValue& f : fields) {
    named.push_back(led.fields[f.slot].name + "=" + std::to_string(f.value->value));
  }
  EXPECT_EQ(named, (std::vector<std::string>{"off=307", "full_on=0", "full_off=0"}));
}

TEST(Check, RateLimitOnOneChannel) {
  const Checked c = run(std::string(kPca) + "limit t -> esc.led(1) 1 per job else ignore\n");
  EXPECT_TRUE(c.diags.empty()) << c.diags[0].rendered;
  ASSERT_EQ(c.policy.rates.size(), 1u);
  EXPECT_EQ(c.policy.rates[0].index, 1);
  const Checked bad = run(std::string(kPca) + "limit t -> esc.led(16) 1 per job else ignore\n");
  EXPECT_EQ(bad.ids(), (std::vector<std::string>{"E0501"}));
}

TEST(Check, ChannelRangeIsJudgedAsAWhole) {
  // `index >= 0` alone always holds; `index in 0..1` refuses channels 2..15.
  EXPECT_TRUE(run(std::string(kPca) + "invariant C on esc.led: require index in 0..1 else ignore\n")
                  .diags.empty());
  EXPECT_TRUE(run(std::string(kPca) + "invariant C on esc.led: require off in 0..300 else ignore\n")
                  .diags.empty());
  // Every channel of a 16-channel group is in 0..15: that one is always true.
  const Checked all =
      run(std::string(kPca) + "invariant C on esc.led: require index in 0..15 else ignore\n");
  EXPECT_EQ(all.ids(), (std::vector<std::string>{"W0704", "W0703"}));
  const Checked none =
      run(std::string(kPca) + "invariant C on esc.led: require index in 16..20 else ignore\n");
  EXPECT_EQ(none.ids(), (std::vector<std::string>{"W0704", "W0703"}));
}

}  // namespace
}  // namespace contego::policy
