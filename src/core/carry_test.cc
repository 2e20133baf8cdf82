// Reload in place (Checker::carry_from): a new image takes over the old
// checker's model for the records the host pairs, and refuses pairs that
// disagree.
#include <gtest/gtest.h>
#include <numeric>

#include "core/test_fixtures.h"

namespace contego::core {
namespace {

using namespace testing::arm_tests;  // NOLINT(google-build-using-namespace)
namespace rover = testing::rover;

// Every record paired with the one of the same id (the host pairs by name;
// for one model edited in place, names and ids agree).
struct IdentityPairs {
  explicit IdentityPairs(const image::ImageModel& m)
      : tasks(ids(m.tasks.size())),
        devices(ids(m.devices.size())),
        commands(ids(m.commands.size())),
        rates(ids(m.rates.size())),
        invariants(ids(m.invariants.size())) {}
  static std::vector<uint16_t> ids(size_t n) {
    std::vector<uint16_t> v(n);
    std::iota(v.begin(), v.end(), uint16_t{0});
    return v;
  }
  Checker::CarryMap map() const {
    return {tasks.data(), devices.data(), commands.data(), rates.data(), invariants.data()};
  }
  std::vector<uint16_t> tasks, devices, commands, rates, invariants;
};

class CarryTest : public ::testing::Test {
 protected:
  // A second checker with `m` loaded, beside the harness's.
  static std::unique_ptr<Harness> loaded(const image::ImageModel& m) {
    auto h = std::make_unique<Harness>();
    EXPECT_EQ(h->load(m).status, LoadStatus::kOk);
    return h;
  }
  static Verdict arm_write(Harness& h, Bytes bytes, uint64_t now) {
    return h.check(arm::kController, kAddr, std::move(bytes), now);
  }
};

TEST_F(CarryTest, AnArmSequenceKeepsItsPositionAcrossAReload) {
  Harness old;
  ASSERT_EQ(old.load(arm::model()).status, LoadStatus::kOk);
  ASSERT_TRUE(old.checker->seed_register(arm::kArm, 0x00, 0x21));
  ASSERT_EQ(arm_write(old, {kLed5, 0, 0, 0xA4, 0x01}, 10).decision, Decision::kAllow);  // 420

  auto fresh = loaded(arm::model());
  auto carried = loaded(arm::model());
  const IdentityPairs pairs(arm::model());
  const Checker::CarryResult r = carried->checker->carry_from(*old.checker, pairs.map());
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.staged_dropped, 0u);
  EXPECT_EQ(carried->checker->model_crc(), old.checker->model_crc());
  // The gripper closed (420): the next is 577, as before the reload.
  EXPECT_EQ(arm_write(*carried, {kLed5, 0, 0, 0x41, 0x02}, 20).decision, Decision::kAllow);
  // Started afresh, the same command would have been refused (swapped step).
  ASSERT_TRUE(fresh->checker->seed_register(arm::kArm, 0x00, 0x21));
  EXPECT_EQ(arm_write(*fresh, {kLed5, 0, 0, 0x41, 0x02}, 20).decision, Decision::kReject);
}

TEST_F(CarryTest, AHalfWrittenRegisterGroupCompletesAfterAReload) {
  Harness old;
  ASSERT_EQ(old.load(arm::model()).status, LoadStatus::kOk);
  ASSERT_TRUE(old.checker->seed_register(arm::kArm, 0x00, 0x01));  // auto-increment off
  for (uint8_t k = 0; k < 3; ++k) {
    ASSERT_EQ(arm_write(old, {static_cast<uint8_t>(kLed4 + k), k == 2 ? uint8_t{0x77} : uint8_t{0}},
                        10 + k)
                  .reason,
              Reason::kStaged);
  }
  auto carried = loaded(arm::model());
  const IdentityPairs pairs(arm::model());
  ASSERT_TRUE(carried->checker->carry_from(*old.checker, pairs.map()).ok);
  const Verdict v = arm_write(*carried, {kLed4 + 3, 0x01}, 20);  // OFF_H: the group commits
  EXPECT_EQ(v.decision, Decision::kAllow);
  uint8_t off_l = 0;
  ASSERT_TRUE(carried->checker->shadow(arm::kArm, kLed4 + 2, &off_l));
  EXPECT_EQ(off_l, 0x77);
}

TEST_F(CarryTest, StagedWritesOfAnUnpairedTaskAreDroppedAndCounted) {
  Harness old;
  ASSERT_EQ(old.load(arm::model()).status, LoadStatus::kOk);
  ASSERT_TRUE(old.checker->seed_register(arm::kArm, 0x00, 0x01));
  ASSERT_EQ(arm_write(old, {kLed4, 0}, 10).reason, Reason::kStaged);
  auto carried = loaded(arm::model());
  IdentityPairs pairs(arm::model());
  pairs.tasks[arm::kController] = kNone;
  const Checker::CarryResult r = carried->checker->carry_from(*old.checker, pairs.map());
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.staged_dropped, 1u);
}

TEST_F(CarryTest, AJobsRateCountCarriesAndTheNewLimitApplies) {
  Harness old;
  ASSERT_EQ(old.load(rover::model()).status, LoadStatus::kOk);
  auto speed = [](Harness& h, uint32_t job) {
    return h.check(rover::kFollower, 0x08, {70, 90, 0, 0}, 1000 + job, job).decision;
  };
  ASSERT_EQ(speed(old, 5), Decision::kAllow);
  ASSERT_EQ(speed(old, 5), Decision::kAllow);
  ASSERT_EQ(speed(old, 5), Decision::kIgnore);  // 2 per job
  image::ImageModel raised = rover::model();
  raised.rates[0].record.max_per_job = 3;  // the ignored one did not count
  auto carried = loaded(raised);
  const IdentityPairs pairs(raised);
  ASSERT_TRUE(carried->checker->carry_from(*old.checker, pairs.map()).ok);
  EXPECT_EQ(speed(*carried, 5), Decision::kAllow);  // the 3rd counted command of job 5
  EXPECT_EQ(speed(*carried, 5), Decision::kIgnore);
  EXPECT_EQ(speed(*carried, 6), Decision::kAllow);  // a new job: a new count
}

TEST_F(CarryTest, PairsThatDisagreeAreRefusedAndNothingIsTaken) {
  Harness old;
  ASSERT_EQ(old.load(arm::model()).status, LoadStatus::kOk);
  ASSERT_TRUE(old.checker->seed_register(arm::kArm, 0x00, 0x21));
  ASSERT_EQ(arm_write(old, {kLed5, 0, 0, 0xA4, 0x01}, 10).decision, Decision::kAllow);

  image::ImageModel moved = arm::model();
  moved.devices[0].record.addr = 0x41;  // another chip under the same name
  moved.aliases.clear();
  auto other = loaded(moved);
  const uint32_t before = other->checker->model_crc();
  const IdentityPairs pairs(moved);
  EXPECT_FALSE(other->checker->carry_from(*old.checker, pairs.map()).ok);
  EXPECT_EQ(other->checker->model_crc(), before);

  auto same = loaded(arm::model());
  IdentityPairs out_of_range(arm::model());
  out_of_range.invariants[0] = 7;
  EXPECT_FALSE(same->checker->carry_from(*old.checker, out_of_range.map()).ok);
  IdentityPairs device_unpaired(arm::model());
  device_unpaired.devices[0] = kNone;  // its commands and invariants cannot stay paired
  EXPECT_FALSE(same->checker->carry_from(*old.checker, device_unpaired.map()).ok);
  // In a transfer: refused too.
  same->checker->begin_transfer();
  EXPECT_FALSE(same->checker->carry_from(*old.checker, IdentityPairs(arm::model()).map()).ok);
  same->checker->abort_transfer(Decision::kReject);
}

}  // namespace
}  // namespace contego::core
