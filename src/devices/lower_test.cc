#include "devices/lower.h"

#include <gtest/gtest.h>

#include "contego/core/limits.h"

#include "devices/codec.h"

namespace contego::devices {
namespace {

DeviceBinding binding(std::string name, uint16_t addr) {
  DeviceBinding b;
  b.name = std::move(name);
  b.bus = 1;
  b.addr = addr;
  return b;
}

// The three built-in devices of the paper's rover and arm, in one model.
image::ImageModel rover_and_arm(uint16_t ids[3]) {
  image::ImageModel m;
  DeviceBinding line = binding("line", 0x06);
  line.sample_period_us = 10000;
  line.max_sample_age_us = 50000;
  ids[0] = *append_device(m, *find_builtin_profile("gopigo2"), binding("gopigo", 0x08));
  ids[1] = *append_device(m, *find_builtin_profile("line_follower"), line);
  ids[2] = *append_device(m, *find_builtin_profile("pca9685"), binding("arm", 0x40));
  return m;
}

TEST(AppendDevice, RecordsAreContiguousAndNamed) {
  uint16_t ids[3];
  image::ImageModel m = rover_and_arm(ids);
  EXPECT_EQ(ids[0], 0);
  EXPECT_EQ(ids[1], 1);
  EXPECT_EQ(ids[2], 2);
  ASSERT_EQ(m.devices.size(), 3u);
  EXPECT_EQ(m.devices[0].name, "gopigo");
  EXPECT_EQ(m.devices[2].name, "arm");
  uint32_t next_command = 0;
  uint32_t next_field = 0;
  for (uint16_t d = 0; d < 3; ++d) {
    const core::DeviceRecord& r = m.devices[d].record;
    EXPECT_EQ(r.command_first, next_command);
    for (uint32_t k = r.command_first; k < uint32_t{r.command_first} + r.command_count; ++k) {
      const core::CommandRecord& c = m.commands[k].record;
      EXPECT_EQ(c.device, d);
      EXPECT_EQ(c.field_first, next_field) << m.commands[k].name;
      EXPECT_FALSE(m.commands[k].name.empty());
      next_field += c.field_count;
    }
    next_command += r.command_count;
  }
  EXPECT_EQ(next_command, m.commands.size());
  EXPECT_EQ(next_field, m.fields.size());
  for (const auto& f : m.fields) EXPECT_FALSE(f.name.empty());
}

TEST(AppendDevice, DeviceRecordCarriesProfileAndBinding) {
  uint16_t ids[3];
  image::ImageModel m = rover_and_arm(ids);
  const core::DeviceRecord& g = m.devices[ids[0]].record;
  EXPECT_EQ(g.profile, core::Profile::kFrame);
  EXPECT_EQ(g.addr, 0x08);
  EXPECT_EQ(g.frame_len, 4);
  EXPECT_EQ(g.prefix_len, 1);
  EXPECT_EQ(g.sample_len, 0);
  const core::DeviceRecord& l = m.devices[ids[1]].record;
  EXPECT_EQ(l.role, core::kRoleSensor);
  EXPECT_EQ(l.sample_request_len, 5);
  EXPECT_EQ(l.sample_request[1], 0x03);
  EXPECT_EQ(l.sample_len, 10);
  EXPECT_EQ(l.sample_period_us, 10000u);
  const core::DeviceRecord& a = m.devices[ids[2]].record;
  EXPECT_EQ(a.profile, core::Profile::kRegisterMap);
  EXPECT_EQ(a.auto_increment, core::AutoIncrement::kBit);
  EXPECT_EQ(a.ai_bit, 5);
}

TEST(AppendDevice, RegisterInitAndAliasesPointAtTheDevice) {
  uint16_t ids[3];
  image::ImageModel m = rover_and_arm(ids);
  bool mode1 = false;
  for (const core::RegisterInitRecord& r : m.register_init) {
    EXPECT_EQ(r.device, ids[2]);
    if (r.reg == 0x00) mode1 = r.value == 0x11;
  }
  EXPECT_TRUE(mode1);
  ASSERT_EQ(m.aliases.size(), 2u);
  EXPECT_EQ(m.aliases[0].addr, 0x70);
  EXPECT_EQ(m.aliases[0].device, ids[2]);
  EXPECT_EQ(m.aliases[0].bus, 1);
  EXPECT_EQ(m.aliases[1].kind, core::AliasKind::kGeneralCall);
  EXPECT_EQ(m.aliases[1].addr, 0);
}

TEST(AppendDevice, GroupsAreSharedWithinADeviceOnly) {
  uint16_t ids[3];
  image::ImageModel m = rover_and_arm(ids);
  auto group = [&](uint16_t dev, const char* name) {
    return m.commands[*find_command(m, dev, name)].record.group;
  };
  EXPECT_EQ(group(ids[0], "fwd"), group(ids[0], "right"));
  EXPECT_EQ(group(ids[0], "fwd"), group(ids[0], "stop"));
  EXPECT_NE(group(ids[0], "fwd"), group(ids[0], "set_left_speed"));
  EXPECT_NE(group(ids[0], "set_left_speed"), group(ids[0], "set_right_speed"));
  EXPECT_NE(group(ids[2], "led"), group(ids[0], "fwd"));
}

TEST(AppendDevice, FindCommandIsScopedToTheDevice) {
  uint16_t ids[3];
  image::ImageModel m = rover_and_arm(ids);
  auto led = find_command(m, ids[2], "led");
  ASSERT_TRUE(led.has_value());
  EXPECT_EQ(m.commands[*led].record.match, 0x06);
  EXPECT_FALSE(find_command(m, ids[0], "led").has_value());
  EXPECT_FALSE(find_command(m, 7, "led").has_value());
  const CommandSpec* c = find_command(*find_builtin_profile("pca9685"), "led");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(find_field_slot(*c, "off"), 1);
  EXPECT_FALSE(find_field_slot(*c, "pulse").has_value());
}

TEST(AppendDevice, RawSignalUsesSampleFieldAndRange) {
  auto s = make_raw_signal(*find_builtin_profile("line_follower"), 1, "raw3");
  ASSERT_TRUE(s.has_value());
  EXPECT_EQ(s->device, 1);
  EXPECT_EQ(s->field.offset, 6);
  EXPECT_EQ(s->valid_max, 1023);
  EXPECT_FALSE(make_raw_signal(*find_builtin_profile("line_follower"), 1, "raw5").has_value());
}

TEST(AppendDevice, RefusesMoreCommandsThanTheCoreHolds) {
  image::ImageModel m;
  const ProfileSpec& g = *find_builtin_profile("gopigo2");  // 41 commands
  ASSERT_TRUE(append_device(m, g, binding("a", 0x08)).ok());
  ASSERT_TRUE(append_device(m, g, binding("b", 0x09)).ok());
  ASSERT_TRUE(append_device(m, g, binding("c", 0x0A)).ok());
  Result<uint16_t> r = append_device(m, g, binding("d", 0x0B));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error(),
            "device 'd' (gopigo2): its 41 commands exceed the image limit of 128 commands");
  EXPECT_EQ(m.devices.size(), 3u);  // nothing half-appended
}

TEST(AppendDevice, RefusesBadAddressAndLatchCount) {
  image::ImageModel m;
  EXPECT_FALSE(append_device(m, *find_builtin_profile("gopigo2"), binding("g", 0x80)).ok());
  DeviceBinding b = binding("g", 0x08);
  b.latch_mode = core::LatchMode::kHoldSafe;
  b.latch_count = 0;
  EXPECT_FALSE(append_device(m, *find_builtin_profile("gopigo2"), b).ok());
  EXPECT_TRUE(m.devices.empty());
}

TEST(Regmap, DeclaredRegistersBecomeCommandsWithAValueField) {
  RegmapDecl d;
  d.name = "valve";
  d.auto_increment = true;
  d.registers = {{"level", 0x01, 1, false, false, 0, 100, "%"},
                 {"flow", 0x02, 2, false, false, 0, 4000, ""}};
  d.forbidden = {{0x10, 0xFF}};
  Result<ProfileSpec> p = make_regmap_profile(d);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->auto_increment, core::AutoIncrement::kAlways);
  ASSERT_EQ(p->commands.size(), 3u);
  EXPECT_EQ(p->commands[2].command_class, core::CommandClass::kForbidden);
  EXPECT_EQ(p->commands[2].repeat, 240);
  // Auto-increment: a 3-byte write to 0x02 is flow, little-endian.
  EXPECT_EQ(*describe(*p, std::vector<uint8_t>{0x02, 0xA0, 0x0F}), "flow(value=4000)");
  EXPECT_EQ(*describe(*p, std::vector<uint8_t>{0x01, 0x32}), "level(value=50)");
  EXPECT_EQ(*describe(*p, std::vector<uint8_t>{0x20, 0x00}), "forbid_0x10(16)");
  EXPECT_FALSE(describe(*p, std::vector<uint8_t>{0x05, 0x00}).ok());  // undeclared register
  std::vector<FieldValue> too_much = {{"value", 101}};
  EXPECT_FALSE(encode_command(*p, "level", too_much).ok());
}

TEST(Regmap, FullForbiddenRangeSplitsIntoTwoCommands) {
  RegmapDecl d;
  d.name = "locked";
  d.forbidden = {{0x00, 0xFF}};
  Result<ProfileSpec> p = make_regmap_profile(d);
  ASSERT_TRUE(p.ok()) << p.error();
  ASSERT_EQ(p->commands.size(), 2u);
  EXPECT_EQ(*describe(*p, std::vector<uint8_t>{0xFF, 0x00}), "forbid_0xff()");
}

TEST(Regmap, ErrorsNameTheRegister) {
  RegmapDecl d;
  d.name = "bad";
  d.registers = {{"a", 0x01, 2, false, false, 0, 10, ""}, {"b", 0x02, 1, false, false, 0, 10, ""}};
  Result<ProfileSpec> p = make_regmap_profile(d);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error(), "profile 'bad' command 'b': register 0x02 already belongs to 'a'");
  d.registers = {{"wide", 0x01, 1, false, false, 0, 300, ""}};
  p = make_regmap_profile(d);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().find("range 0..300 not representable"), std::string::npos) << p.error();
  d.registers = {{"big", 0xFE, 4, false, false, 0, 10, ""}};
  EXPECT_NE(make_regmap_profile(d).error().find("beyond 0xff"), std::string::npos);
}

TEST(Regmap, SensorSampleFields) {
  RegmapDecl d;
  d.name = "tank";
  d.role = core::kRoleSensor;
  d.sample_request = {0x00};
  d.sample_len = 4;
  d.sample_fields = {make_int_field("level", 0, 2, true, false, 0, 1000, "mm"),
                     make_int_field("temp", 2, 2, true, true, -400, 1250, "dC")};
  Result<ProfileSpec> p = make_regmap_profile(d);
  ASSERT_TRUE(p.ok()) << p.error();
  std::vector<FieldValue> v = {{"level", 900}, {"temp", -5}};
  auto s = encode_sample(*p, v);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(*s, (std::vector<uint8_t>{0x03, 0x84, 0xFF, 0xFB}));
  auto sig = make_raw_signal(*p, 4, "temp");
  ASSERT_TRUE(sig.has_value());
  EXPECT_EQ(*extract_field(sig->field, *s), -5);
}

}  // namespace
}  // namespace contego::devices
