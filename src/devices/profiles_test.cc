#include <gtest/gtest.h>

#include "devices/lower.h"
#include "devices/profile.h"

namespace contego::devices {
namespace {

const CommandSpec& cmd(const ProfileSpec& p, std::string_view name) {
  const CommandSpec* c = find_command(p, name);
  EXPECT_NE(c, nullptr) << name;
  static const CommandSpec kMissing;
  return c != nullptr ? *c : kMissing;
}

TEST(BuiltinProfiles, AllThreeExistAndValidate) {
  ASSERT_EQ(builtin_profiles().size(), 3u);
  for (const char* name : {"gopigo2", "line_follower", "pca9685"}) {
    const ProfileSpec* p = find_builtin_profile(name);
    ASSERT_NE(p, nullptr) << name;
    Status s = validate_profile(*p);
    EXPECT_TRUE(s.ok()) << s.error();
  }
  EXPECT_EQ(find_builtin_profile("gopigo3"), nullptr);
}

TEST(BuiltinProfiles, GopigoHasEveryOpcodeOfTheFirmwareTable) {
  const ProfileSpec& p = *find_builtin_profile("gopigo2");
  EXPECT_EQ(p.frame_len, 4);
  EXPECT_EQ(p.prefix_len, 1);
  // Every command code of the vendor table (firmware 1.6).
  for (int op : {119, 105, 107, 115, 97, 98,  100, 110, 120, 116, 103, 70, 71, 111,
                 112, 50,  53,  51,  52, 114, 118, 117, 101, 61,  60,  80, 81, 20,
                 30,  31,  32,  12,  13, 14,  15,  16,  21,  22,  25,  10, 11}) {
    int found = 0;
    for (const CommandSpec& c : p.commands) found += c.match == op ? 1 : 0;
    EXPECT_EQ(found, 1) << "opcode " << op;
  }
  EXPECT_EQ(p.commands.size(), 41u);
}

TEST(BuiltinProfiles, GopigoClassesSeparateQueriesAndFactoryTests) {
  const ProfileSpec& p = *find_builtin_profile("gopigo2");
  for (const char* q : {"enc_read", "volt", "us_dist", "fw_ver", "read_motor_speed", "analog_read",
                        "digital_read", "trim_read", "cpu_speed"}) {
    EXPECT_EQ(cmd(p, q).command_class, core::CommandClass::kQuery) << q;
  }
  EXPECT_EQ(cmd(p, "factory_test1").command_class, core::CommandClass::kForbidden);
  EXPECT_EQ(cmd(p, "factory_test2").command_class, core::CommandClass::kForbidden);
  for (const char* a : {"fwd", "set_left_speed", "motor1", "digital_write", "trim_write",
                        "disable_com_timeout", "enc_tgt"}) {
    EXPECT_EQ(cmd(p, a).command_class, core::CommandClass::kActuate) << a;
  }
}

TEST(BuiltinProfiles, GopigoSubstitutionGroups) {
  const ProfileSpec& p = *find_builtin_profile("gopigo2");
  for (const char* m :
       {"fwd", "fwd_pid", "bwd", "bwd_pid", "left", "left_rot", "right", "right_rot", "stop"}) {
    EXPECT_EQ(cmd(p, m).group, "motion") << m;
  }
  EXPECT_EQ(cmd(p, "set_left_speed").group, "left_speed");
  EXPECT_EQ(cmd(p, "set_right_speed").group, "right_speed");
  EXPECT_EQ(cmd(p, "increase_speed").group, "speed_step");
  EXPECT_EQ(cmd(p, "decrease_speed").group, "speed_step");
  EXPECT_NE(cmd(p, "motor1").group, cmd(p, "motor2").group);
}

TEST(BuiltinProfiles, LineFollowerSamplesFiveBigEndianReadings) {
  const ProfileSpec& p = *find_builtin_profile("line_follower");
  EXPECT_EQ(p.role, core::kRoleSensor);
  EXPECT_EQ(p.sample_request, (std::vector<uint8_t>{0x01, 0x03, 0x00, 0x00, 0x00}));
  EXPECT_EQ(p.sample_len, 10);
  ASSERT_EQ(p.sample_fields.size(), 5u);
  EXPECT_EQ(p.sample_fields[4].name, "raw4");
  EXPECT_EQ(p.sample_fields[4].geometry.offset, 8);
  EXPECT_EQ(p.sample_fields[4].geometry.flags, core::kFieldBigEndian);
  EXPECT_EQ(p.sample_fields[4].max, 1023);
  EXPECT_EQ(cmd(p, "read_sensors").match, 3);
  EXPECT_EQ(cmd(p, "read_sensors").command_class, core::CommandClass::kQuery);
}

TEST(BuiltinProfiles, Pca9685RegisterMap) {
  const ProfileSpec& p = *find_builtin_profile("pca9685");
  EXPECT_EQ(p.kind, core::Profile::kRegisterMap);
  EXPECT_EQ(p.auto_increment, core::AutoIncrement::kBit);
  EXPECT_EQ(p.ai_reg, 0);
  EXPECT_EQ(p.ai_bit, 5);
  const CommandSpec& led = cmd(p, "led");
  EXPECT_EQ(led.match, 0x06);
  EXPECT_EQ(led.group_len, 4);
  EXPECT_EQ(led.repeat, 16);
  EXPECT_EQ(led.stride, 4);
  EXPECT_EQ(cmd(p, "all_led").match, 0xFA);
  EXPECT_EQ(cmd(p, "prescale").fields.at(0).min, 3);
  EXPECT_EQ(cmd(p, "testmode").command_class, core::CommandClass::kForbidden);
  EXPECT_EQ(cmd(p, "mode1").fields.size(), 8u);
  ASSERT_EQ(p.aliases.size(), 2u);
  EXPECT_EQ(p.aliases[0].addr, 0x70);
  EXPECT_EQ(p.aliases[1].kind, core::AliasKind::kGeneralCall);
  // No command covers the reserved registers 0x46..0xF9.
  for (const CommandSpec& c : p.commands) {
    const int last = c.match + (c.repeat - 1) * c.stride + c.group_len - 1;
    EXPECT_TRUE(last < 0x46 || c.match > 0xF9) << c.name;
  }
}

TEST(ValidateProfile, RefusesOverlappingRegisterGroups) {
  ProfileSpec p = *find_builtin_profile("pca9685");
  for (const CommandSpec& c : p.commands) {
    if (c.name == "prescale") {
      p.commands.push_back(c);
      break;
    }
  }
  p.commands.back().name = "clash";
  p.commands.back().match = 0x07;  // inside led channel 0
  Status s = validate_profile(p);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("register 0x07 already belongs to 'led'"), std::string::npos)
      << s.error();
}

TEST(ValidateProfile, RefusesFieldOutsideFrameAndUnrepresentableRange) {
  ProfileSpec p = *find_builtin_profile("gopigo2");
  p.commands[0].fields.push_back(p.commands[11].fields[0]);  // set_left_speed's speed
  p.commands[0].fields.back().geometry.offset = 4;
  Status s = validate_profile(p);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("outside the 4 bytes"), std::string::npos) << s.error();

  p = *find_builtin_profile("gopigo2");
  ProfileSpec q = p;
  for (CommandSpec& c : q.commands) {
    if (c.name == "set_left_speed") c.fields[0].max = 256;
  }
  s = validate_profile(q);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("range 0..256 not representable"), std::string::npos) << s.error();
}

TEST(ValidateProfile, RefusesDuplicateOpcode) {
  ProfileSpec p = *find_builtin_profile("gopigo2");
  p.commands[1].match = p.commands[0].match;
  EXPECT_FALSE(validate_profile(p).ok());
}

}  // namespace
}  // namespace contego::devices
