// Host image tools: serialize → deserialize round trip, dump, crc32, and
// clear errors for damaged input.
#include "image/image_model.h"

#include <gtest/gtest.h>

#include "contego/core/checker.h"

#include "core/test_fixtures.h"

namespace contego::image {
namespace {

namespace rover = core::testing::rover;
namespace arm = core::testing::arm;

TEST(ImageModelTest, Crc32MatchesZlib) {
  const std::string text = "123456789";
  EXPECT_EQ(crc32({reinterpret_cast<const uint8_t*>(text.data()), text.size()}), 0xCBF43926u);
  EXPECT_EQ(crc32({}), 0u);
}

TEST(ImageModelTest, RoundTripIsByteIdentical) {
  for (const ImageModel& m : {rover::model(), arm::model()}) {
    const std::vector<uint8_t> bytes = serialize(m);
    Result<ImageModel> back = deserialize(bytes);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(serialize(*back), bytes);
    EXPECT_EQ(back->tasks.size(), m.tasks.size());
    EXPECT_EQ(back->tasks[0].name, m.tasks[0].name);
    EXPECT_EQ(back->commands.back().name, m.commands.back().name);
    EXPECT_EQ(back->code.size(), m.code.size());
  }
}

TEST(ImageModelTest, SerializedImagesPassTheVerifier) {
  auto checker = std::make_unique<core::Checker>();
  for (const ImageModel& m : {rover::model(), arm::model()}) {
    const std::vector<uint8_t> bytes = serialize(m);
    EXPECT_EQ(checker->load(bytes.data(), static_cast<uint32_t>(bytes.size())).status,
              core::LoadStatus::kOk);
    EXPECT_EQ(bytes.size() % 4, 0u);
  }
}

TEST(ImageModelTest, DeserializeNamesWhatIsWrong) {
  std::vector<uint8_t> bytes = serialize(rover::model());
  Result<ImageModel> r = deserialize(std::span<const uint8_t>(bytes).first(10));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("shorter than the 32-byte header"), std::string::npos) << r.error();
  bytes[0] = 'X';
  r = deserialize(bytes);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("bad magic"), std::string::npos) << r.error();
  bytes = serialize(rover::model());
  bytes.push_back(0);
  r = deserialize(bytes);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("header says"), std::string::npos) << r.error();
}

TEST(ImageModelTest, DumpListsTablesAndDisassemblesEveryProgram) {
  const std::string text = dump(rover::model());
  for (const char* line :
       {"t0 follower: period 200000us", "d0 gopigo: role A profile frame i2c-1 0x08",
        "s5 pos: derived", "i0 INV1", "i2 INV3", "failsubst", "signal s5  ; pos", "jz +", "ret"}) {
    EXPECT_NE(text.find(line), std::string::npos) << line << " is not in\n" << text;
  }
  const std::string a = dump(arm::model());
  for (const char* line : {"ai bit 5 of 0x00", "group 4 x16 stride 4", "setstate"}) {
    EXPECT_NE(a.find(line), std::string::npos) << line << " is not in\n" << a;
  }
}

}  // namespace
}  // namespace contego::image
