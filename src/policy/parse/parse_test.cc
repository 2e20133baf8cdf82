#include "policy/parse/parse.h"

#include <gtest/gtest.h>
#include <string>

namespace contego::policy {
namespace {

struct Parsed {
  ast::File file;
  std::vector<Diagnostic> diags;
};

Parsed run(const std::string& text) {
  SourceBuffer src("t.policy", text);
  DiagnosticEmitter d(src);
  Parsed p;
  p.file = parse(lex(src, d), d);
  p.diags = d.take();
  return p;
}

TEST(Parse, DraftExamplesParse) {
  const Parsed p = run(R"(
const THETA = 2500
device gopigo : gopigo2 at i2c-1 0x08 {
  safe stop()
  latch after 3 violations within 1s
}
device valve : regmap at i2c-1 0x20 {
  auto_increment
  register 0x01 level : u8 range 0..100
  register 0x02..0x03 flow : u16le range 0..4000
  forbid 0x10..0xFF
}
signal pos = line_position(line.raw, white=[1,2], black=[3,4], weights=[-1,1])
task follower { exe "/usr/bin/python3"; period 200ms; deadline 200ms; wcet 40ms; priority 2 }
overhead 20us
allow follower -> gopigo
allow follower reads line
limit follower -> gopigo.{set_left_speed, set_right_speed} 2 per job else failsafe speed=80
invariant INV1 on gopigo:
  when pos < -THETA expect set_left_speed(85), set_right_speed(85), right()
  else failsafe expected
invariant PAN on camera.led: require index != 0 or off in 150..600 else ignore
invariant GRIP on arm.led(5): sequence off [420, 577] else failsafe expected
invariant BUZZ on buzzer.level: when not (level > 80 or temp not in 5..40) expect level(0) else reject EPERM
)");
  EXPECT_TRUE(p.diags.empty()) << p.diags[0].rendered;
  EXPECT_EQ(p.file.consts.size(), 1u);
  EXPECT_EQ(p.file.devices.size(), 2u);
  EXPECT_EQ(p.file.devices[1].registers.size(), 2u);
  EXPECT_EQ(p.file.devices[1].forbid.size(), 1u);
  EXPECT_EQ(p.file.tasks[0].properties.size(), 5u);
  EXPECT_EQ(p.file.invariants.size(), 4u);
  EXPECT_EQ(p.file.invariants[0].expect.size(), 3u);
  EXPECT_EQ(p.file.invariants[2].form, ast::InvariantForm::kSequence);
  EXPECT_TRUE(p.file.invariants[3].when->kind == ast::ExprKind::kUnary);
  EXPECT_EQ(p.file.limits[0].response.kind, ast::ResponseKind::kFailsafeAssign);
}

TEST(Parse, RecoversAtTheNextStatementAndReportsEachError) {
  const Parsed p = run(R"(
const A = (1 +
device d : gopigo2 at i2c-1 0x08
task t { period 10ms wcet }
invariant X on d when
const B = 2
)");
  ASSERT_EQ(p.diags.size(), 3u);
  EXPECT_EQ(p.diags[0].line, 3u);  // `device` where `)` was expected... reported at `device`
  EXPECT_EQ(p.diags[1].line, 4u);
  EXPECT_EQ(p.diags[2].line, 5u);
  EXPECT_EQ(p.file.devices.size(), 1u);
  EXPECT_EQ(p.file.consts.size(), 1u);  // B
  ASSERT_EQ(p.file.tasks.size(), 1u);
  EXPECT_TRUE(p.file.tasks[0].incomplete);
}

TEST(Parse, NestingLimitStopsDeepExpressions) {
  std::string deep = "const A = " + std::string(1000, '(') + "1" + std::string(1000, ')') + "\n";
  const Parsed p = run(deep);
  ASSERT_EQ(p.diags.size(), 1u);
  EXPECT_EQ(p.diags[0].id, "E0203");
}

// Operator and postfix chains build a tall tree without recursing in the
// parser; every later pass recurses over it, so the parser bounds its height.
std::string chain(const std::string& term, const std::string& op, int n) {
  std::string s = term;
  for (int i = 1; i < n; ++i) s += op + term;
  return s;
}

TEST(Parse, LongOperatorChainsAreRefusedNotRecursedInto) {
  const Parsed p = run("const A = " + chain("1", " + ", 30000) + "\n");
  ASSERT_EQ(p.diags.size(), 1u);
  EXPECT_EQ(p.diags[0].id, "E0207");
  const Parsed postfix = run("const A = x" + chain("", "[0]", 30000) + "\n");
  ASSERT_EQ(postfix.diags.size(), 1u);
  EXPECT_EQ(postfix.diags[0].id, "E0207");
  // The limit is the height: 256 operators are the most a chain may have.
  EXPECT_TRUE(run("const A = " + chain("1", " + ", 256) + "\n").diags.empty());
  EXPECT_EQ(run("const A = " + chain("1", " + ", 258) + "\n").diags.size(), 1u);
}

TEST(Parse, HugeSetsAndListsAreRefused) {
  const Parsed p = run("const A = 1 in {" + chain("1", ", ", 100000) + "}\n");
  ASSERT_EQ(p.diags.size(), 1u);
  EXPECT_EQ(p.diags[0].id, "E0208");
  EXPECT_NE(p.diags[0].message.find("a set of more than 256"), std::string::npos)
      << p.diags[0].message;
  EXPECT_EQ(run("const A = [" + chain("1", ", ", 257) + "]\n").diags.size(), 1u);
  EXPECT_TRUE(run("const A = 1 in {" + chain("1", ", ", 256) + "}\n").diags.empty());
}

TEST(Parse, GarbageDoesNotLoopForever) {
  const Parsed p = run("} } ) ( { device { { ]");
  EXPECT_FALSE(p.diags.empty());
}

}  // namespace
}  // namespace contego::policy
