#include "policytest/test_file.h"

#include <gtest/gtest.h>

namespace contego::policytest {
namespace {

ParseResult parse(const std::string& text) { return parse_test_file("t.test", text); }

std::vector<std::string> rendered(const ParseResult& r) {
  std::vector<std::string> out;
  for (const auto& e : r.errors) out.push_back(e.rendered);
  return out;
}

TEST(TestFileParser, ParsesDefaultsCasesAndEveryStepForm) {
  ParseResult r = parse(R"(# rover tests
task follower
job 1

test "forward on the line" {
  sensor line raw = [800, 900, 1015, 850, 800]
  at 200ms
  send gopigo.set_left_speed(80)        -> allow
  write i2c-1 0x08 [01 6E 00 00 00]     -> failsafe fwd() rule INV3
  after 10ms
  smbus i2c-1 0x40 byte_data 0x1C 0xA4  -> ignore reason rate-exceeded
  smbus i2c-1 0x40 word_data 0x1C 577   -> allow
  smbus i2c-1 0x40 block_data 0x06 [00 00 41 02] -> allow
  read i2c-1 0x06                       -> allow
  send arm.led(5, off=420)              -> reject EPERM rule access
  sensor tank level=900 temp=-5
  sensor line none
  sensor line sample [02 ff 03 2f]
}
)");
  ASSERT_TRUE(r.ok()) << rendered(r)[0];
  ASSERT_EQ(r.file.defaults.size(), 2u);
  EXPECT_EQ(std::get<SetTask>(r.file.defaults[0]).task, "follower");
  ASSERT_EQ(r.file.cases.size(), 1u);
  const TestCase& c = r.file.cases[0];
  EXPECT_EQ(c.name, "forward on the line");
  ASSERT_EQ(c.actions.size(), 13u);

  const auto& sensor = std::get<SetSensor>(c.actions[0]);
  EXPECT_EQ(sensor.device, "line");
  EXPECT_EQ(sensor.fields[0].first, "raw");
  EXPECT_EQ(sensor.fields[0].second, (std::vector<int64_t>{800, 900, 1015, 850, 800}));
  EXPECT_TRUE(sensor.is_list[0]);
  EXPECT_EQ(std::get<SetTime>(c.actions[1]).us, 200000u);

  const auto& send = std::get<Step>(c.actions[2]);
  ASSERT_TRUE(send.call.has_value());
  EXPECT_EQ(send.call->device, "gopigo");
  EXPECT_EQ(send.call->command, "set_left_speed");
  EXPECT_EQ(send.call->args[0].value, 80);
  EXPECT_EQ(send.text, "send gopigo.set_left_speed(80)");
  EXPECT_EQ(send.expect.decision, core::Decision::kAllow);
  EXPECT_EQ(send.expect.text, "allow");
  EXPECT_EQ(send.loc.line, 8u);

  const auto& write = std::get<Step>(c.actions[3]);
  EXPECT_EQ(write.bus, 1);
  EXPECT_EQ(write.addr, 0x08);
  EXPECT_EQ(write.bytes, (std::vector<uint8_t>{0x01, 0x6E, 0x00, 0x00, 0x00}));
  EXPECT_EQ(write.expect.decision, core::Decision::kFailsafe);
  ASSERT_EQ(write.expect.substitutes.size(), 1u);
  EXPECT_EQ(write.expect.substitutes[0].command, "fwd");
  EXPECT_EQ(write.expect.rule, "INV3");
  EXPECT_EQ(write.expect.text, "failsafe fwd() rule INV3");

  EXPECT_TRUE(std::get<SetTime>(c.actions[4]).relative);
  EXPECT_EQ(std::get<Step>(c.actions[5]).bytes, (std::vector<uint8_t>{0x1C, 0xA4}));
  EXPECT_EQ(std::get<Step>(c.actions[5]).expect.reason, "rate-exceeded");
  // WORD_DATA: little-endian word after the command byte.
  EXPECT_EQ(std::get<Step>(c.actions[6]).bytes, (std::vector<uint8_t>{0x1C, 0x41, 0x02}));
  // BLOCK_DATA carries the count on the wire.
  EXPECT_EQ(std::get<Step>(c.actions[7]).bytes,
            (std::vector<uint8_t>{0x06, 0x04, 0x00, 0x00, 0x41, 0x02}));
  EXPECT_EQ(std::get<Step>(c.actions[8]).kind, core::TxKind::kRead);
  EXPECT_TRUE(std::get<Step>(c.actions[8]).bytes.empty());

  const auto& led = std::get<Step>(c.actions[9]);
  EXPECT_EQ(led.call->args[0].name, "");
  EXPECT_EQ(led.call->args[0].value, 5);
  EXPECT_EQ(led.call->args[1].name, "off");
  EXPECT_EQ(led.expect.decision, core::Decision::kReject);
  EXPECT_EQ(led.expect.reply_errno, 1);

  const auto& tank = std::get<SetSensor>(c.actions[10]);
  EXPECT_EQ(tank.fields[1].second[0], -5);
  EXPECT_TRUE(std::get<SetSensor>(c.actions[11]).none);
  EXPECT_EQ(*std::get<SetSensor>(c.actions[12]).sample,
            (std::vector<uint8_t>{0x02, 0xFF, 0x03, 0x2F}));
}

TEST(TestFileParser, FailsafeWithSeveralSubstitutesAndNamedFields) {
  ParseResult r = parse(
      "test \"x\" {\n"
      "  send gopigo.fwd() -> failsafe gopigo.set_left_speed(speed=85), right()\n"
      "}\n");
  ASSERT_TRUE(r.ok()) << rendered(r)[0];
  const auto& e = std::get<Step>(r.file.cases[0].actions[0]).expect;
  ASSERT_EQ(e.substitutes.size(), 2u);
  EXPECT_EQ(e.substitutes[0].device, "gopigo");
  EXPECT_EQ(e.substitutes[0].args[0].name, "speed");
  EXPECT_EQ(e.substitutes[1].command, "right");
}

TEST(TestFileParser, ReportsEveryErrorWithFileLineColumn) {
  ParseResult r = parse(
      "test \"a\" {\n"
      "  write i2c-1 0x08 [01 GG] -> allow\n"
      "  send gopigo.fwd() allow\n"
      "  send gopigo.fwd() -> maybe\n"
      "  wait 10ms\n"
      "  at soon\n"
      "  smbus i2c-1 0x40 byte_data 0x1C 300 -> allow\n"
      "  send gopigo.fwd() -> reject ENOPE\n"
      "}\n"
      "}\n");
  EXPECT_EQ(rendered(r),
            (std::vector<std::string>{
                "t.test:2:24: error: expected a hex byte (00..ff) or ']', found 'GG'",
                "t.test:3:21: error: expected '->' and the expected verdict, found 'allow'",
                "t.test:4:24: error: unknown verdict 'maybe' (expected allow, ignore, reject or "
                "failsafe)",
                "t.test:5:3: error: unknown statement 'wait' (expected task, job, at, after, "
                "sensor, send, write, read or smbus)",
                "t.test:6:6: error: expected a duration such as 200ms, 250us or 1s, found 'soon'",
                "t.test:7:35: error: the data byte 300 outside 0..255",
                "t.test:8:31: error: unknown errno 'ENOPE' (expected a number or one of EPERM, "
                "EIO, EBADF, EAGAIN, EACCES, EBUSY, EINVAL)",
                "t.test:10:1: error: '}' without an open test"}));
}

TEST(TestFileParser, UnclosedAndDuplicateTestsAndStrayCharacters) {
  ParseResult r = parse(
      "test \"a\" {\n"
      "}\n"
      "test \"a\" {\n"
      "  send gopigo.fwd() -> allow $\n"
      "test \"b\" {\n");
  EXPECT_EQ(rendered(r), (std::vector<std::string>{
                             "t.test:3:1: error: test \"a\" already defined at line 1",
                             "t.test:4:30: error: unexpected character '$'",
                             "t.test:5:1: error: test \"a\" is not closed: expected '}' before a "
                             "new test",
                             "t.test:5:1: error: test \"b\" is not closed (expected '}')"}));
}

TEST(TestFileParser, StepsOutsideATestAndEmptyFiles) {
  EXPECT_EQ(rendered(parse("send gopigo.fwd() -> allow\ntest \"a\" {\n}\n")),
            std::vector<std::string>{
                "t.test:1:1: error: a bus step outside a test (expected test \"NAME\" { ... })"});
  EXPECT_EQ(rendered(parse("# nothing\n")),
            std::vector<std::string>{
                "t.test:1:1: error: no test cases (expected test \"NAME\" { ... })"});
  EXPECT_EQ(
      rendered(parse("test \"a\" {\n  send fwd() -> allow\n}\n")),
      std::vector<std::string>{"t.test:2:8: error: expected DEVICE.COMMAND(...) after 'send'"});
}

}  // namespace
}  // namespace contego::policytest
