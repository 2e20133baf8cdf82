#include "bundle/bundle.h"

#include <gtest/gtest.h>
#include <string>

#include "policy/compile.h"

namespace contego::bundle {
namespace {

constexpr const char* kPolicy = R"(
device arm : pca9685 at i2c-1 0x40 { safe led(5, on=0, off=420) }
task arm_init {
  user "root"; exe "/usr/bin/python3"; sessions 2; phase 5ms; ignore_errno EIO
  period 10s; deadline 10s; wcet 50ms; priority 1
  actuations 8
}
task gripper { period 1s; deadline 1s; wcet 20ms; priority 3; actuations 1 }
allow arm_init -> arm
allow gripper -> arm
)";

Bundle compiled() {
  const policy::CompileOutput out = policy::compile_source("arm.policy", kPolicy);
  EXPECT_TRUE(out.ok) << (out.diagnostics.empty() ? "" : out.diagnostics[0].rendered);
  Bundle b;
  b.policy = "arm.policy";
  b.image = out.image;
  for (const auto& t : out.summary.tasks) {
    b.tasks.push_back(
        {t.name, t.exe, t.user, t.group, t.unit, t.cgroup, t.sessions, t.phase_us, t.ignore_errno});
  }
  return b;
}

void expect_refused(const std::string& text, const std::string& needle) {
  const Result<Bundle> r = decode_bundle(text, "robot.bundle");
  ASSERT_FALSE(r.ok()) << "accepted: " << text.substr(0, 200);
  EXPECT_NE(r.error().find("bundle robot.bundle"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find(needle), std::string::npos) << r.error();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(BundleTest, RoundTripKeepsImageAndEveryBinding) {
  const Bundle b = compiled();
  const std::string text = encode_bundle(b);
  EXPECT_EQ(text, encode_bundle(b)) << "one text per bundle";
  const Result<Bundle> back = decode_bundle(text, "robot.bundle");
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->policy, "arm.policy");
  EXPECT_EQ(back->image, b.image);
  ASSERT_EQ(back->tasks.size(), 2u);
  EXPECT_EQ(back->tasks[0].name, "arm_init");
  EXPECT_EQ(back->tasks[0].user, "root");
  EXPECT_EQ(back->tasks[0].exe, "/usr/bin/python3");
  EXPECT_EQ(back->tasks[0].sessions, 2u);
  EXPECT_EQ(back->tasks[0].phase_us, std::optional<uint32_t>(5000));
  EXPECT_EQ(back->tasks[0].ignore_errno, 5);
  EXPECT_EQ(back->tasks[1].ignore_errno, 0);
  EXPECT_EQ(back->tasks[1].name, "gripper");
  EXPECT_TRUE(back->tasks[1].user.empty());
  EXPECT_EQ(back->tasks[1].phase_us, std::nullopt);
  EXPECT_NE(text.find("\"image_sha256\": \"" + image_sha256(b.image) + "\""), std::string::npos);
}

// The reason for bundles: two policies with one image but different
// bindings are two different bundles.
TEST(BundleTest, BindingsChangeTheBundleButNotTheImage) {
  Bundle a = compiled();
  Bundle b = a;
  b.tasks[0].user = "robot";
  EXPECT_EQ(image_sha256(a.image), image_sha256(b.image));
  EXPECT_NE(encode_bundle(a), encode_bundle(b));
}

TEST(BundleTest, DamagedOrForeignBundlesAreRefusedNamingTheField) {
  const std::string text = encode_bundle(compiled());
  expect_refused("", "not a JSON object");
  expect_refused("[1]", "not a JSON object");
  expect_refused(text.substr(0, text.size() / 2), "not a JSON object");
  expect_refused(replaced(text, "contego-policy-bundle", "other"), "format \"other\"");
  expect_refused(replaced(text, "\"version\": 1", "\"version\": 2"), "version 2");
  expect_refused(replaced(text, "\"version\": 1", "\"version\": \"1\""), "\"version\" must be");
  expect_refused(replaced(text, "\"policy\": \"arm.policy\"", "\"policy\": 7"),
                 "\"policy\" must be a string");
  expect_refused(replaced(text, "\"user\": \"root\"", "\"user\": 0"), "tasks[0]: \"user\"");
  expect_refused(replaced(text, "\"sessions\": 2", "\"sessions\": -2"), "tasks[0]: \"sessions\"");
  expect_refused(replaced(text, "\"sessions\": 2", "\"sessions\": 0"), "at least 1");
  expect_refused(replaced(text, "\"ignore_errno\": 5", "\"ignore_errno\": 300"), "from 0 to 255");
  expect_refused(replaced(text, "\"name\": \"gripper\"", "\"name\": \"arm_init\""),
                 "tasks[1]: task 'arm_init' is bound twice");
  expect_refused(replaced(text, "\"name\": \"gripper\"", "\"name\": \"wheels\""),
                 "the image declares no task 'wheels'");
  expect_refused(replaced(text, "\"tasks\": [", "\"tasks\": {\"x\": ["), "");
}

// The host side (budget factor, bus adapters): in the bundle only when
// named, so a bundle without it keeps its text and its signature.
TEST(BundleTest, TheHostSideRoundTripsAndIsCheckedOnRead) {
  Bundle b = compiled();
  const std::string plain = encode_bundle(b);
  EXPECT_EQ(plain.find("budget_factor"), std::string::npos);
  EXPECT_EQ(plain.find("buses"), std::string::npos);
  b.budget_factor = 0;
  b.buses[1] = "/dev/i2c-1";
  const std::string text = encode_bundle(b);
  const Result<Bundle> r = decode_bundle(text, "robot.bundle");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->budget_factor, std::optional<uint32_t>(0));
  ASSERT_EQ(r->buses.size(), 1u);
  EXPECT_EQ(r->buses.at(1), "/dev/i2c-1");
  EXPECT_EQ(encode_bundle(*r), text);
  const Result<Bundle> none = decode_bundle(plain, "robot.bundle");
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->budget_factor.has_value());
  EXPECT_TRUE(none->buses.empty());

  expect_refused(replaced(text, "\"budget_factor\": 0", "\"budget_factor\": -1"),
                 "\"budget_factor\" must be");
  expect_refused(replaced(text, "\"1\": \"/dev/i2c-1\"", "\"2\": \"/dev/i2c-2\""),
                 "no device of the image is on bus 2");
  expect_refused(replaced(text, "\"1\": \"/dev/i2c-1\"", "\"x\": \"/dev/i2c-1\""),
                 "a bus number from 0 to 255");
  expect_refused(replaced(text, "\"1\": \"/dev/i2c-1\"", "\"1000\": \"/dev/i2c-1\""),
                 "a bus number from 0 to 255");
  expect_refused(replaced(text, "\"1\": \"/dev/i2c-1\"", "\"1\": \"i2c-1\""), "absolute path");
  expect_refused(replaced(text, "\"1\": \"/dev/i2c-1\"", "\"1\": 1"), "absolute path");
  expect_refused(replaced(text, "\"buses\": {", "\"buses\": [{"), "");
}

TEST(BundleTest, AnImageChangedInTheFileIsRefused) {
  const Bundle b = compiled();
  const std::string text = encode_bundle(b);
  const size_t at = text.find("\"image\": \"") + 10 + 40;
  std::string flipped = text;
  flipped[at] = flipped[at] == '0' ? '1' : '0';
  expect_refused(flipped, "the file was changed");
  std::string upper = text;
  upper[at] = 'G';
  expect_refused(upper, "not lower-case hex");
  expect_refused(replaced(text, "\"image\": \"", "\"image\": \"0"), "odd number");
}

TEST(BundleTest, AnOversizedTextIsRefusedBeforeParsing) {
  expect_refused(std::string(kMaxBundleBytes + 1, ' '), "more than a bundle may have");
}

}  // namespace
}  // namespace contego::bundle
