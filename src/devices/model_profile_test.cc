#include "devices/model_profile.h"

#include <gtest/gtest.h>

#include "devices/codec.h"
#include "devices/lower.h"

namespace contego::devices {
namespace {

TEST(ProfileFromModel, RecognisesBuiltinProfiles) {
  image::ImageModel m;
  DeviceBinding g{"gopigo", 1, 0x08};
  DeviceBinding a{"arm", 1, 0x40};
  ASSERT_TRUE(append_device(m, *find_builtin_profile("gopigo2"), g).ok());
  ASSERT_TRUE(append_device(m, *find_builtin_profile("pca9685"), a).ok());
  auto p = profile_from_model(m, 1);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->name, "pca9685");
  EXPECT_EQ(profile_from_model(m, 0)->name, "gopigo2");
  EXPECT_FALSE(profile_from_model(m, 2).ok());
}

TEST(ProfileFromModel, RebuildsGenericRegmapWithSampleFieldsFromRawSignals) {
  RegmapDecl d;
  d.name = "tank";
  d.role = core::kRoleSensor | core::kRoleActuator;
  d.registers = {{"alarm", 0x01, 1, false, false, 0, 1, ""}};
  d.sample_request = {0x10};
  d.sample_len = 2;
  d.sample_fields = {make_int_field("level", 0, 2, true, false, 0, 1000)};
  Result<ProfileSpec> decl = make_regmap_profile(d);
  ASSERT_TRUE(decl.ok()) << decl.error();
  image::ImageModel m;
  ASSERT_TRUE(append_device(m, *decl, DeviceBinding{"tank", 1, 0x20}).ok());
  image::Named<core::SignalRecord> sig;
  sig.record = *make_raw_signal(*decl, 0, "level");
  sig.name = "tank.level";
  m.signals.push_back(sig);

  auto p = profile_from_model(m, 0);
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_EQ(p->name, "tank");
  ASSERT_EQ(p->sample_fields.size(), 1u);
  EXPECT_EQ(p->sample_fields[0].name, "level");
  EXPECT_EQ(p->sample_fields[0].max, 1000);
  std::vector<FieldValue> v = {{"level", 513}};
  EXPECT_EQ(*encode_sample(*p, v), (std::vector<uint8_t>{0x02, 0x01}));
  EXPECT_EQ(*describe(*p, std::vector<uint8_t>{0x01, 0x01}), "alarm(value=1)");
}

}  // namespace
}  // namespace contego::devices
