// The documented byte sequences of the device facts, decoded by the trusted
// core from images lowered by devices::append_device. The policy grants full
// access and has no rules, so the verdict and the audit record show the
// core's decoding alone.
#include <gtest/gtest.h>
#include <memory>
#include <string>
#include <vector>

#include "contego/core/checker.h"

#include "core/test_fixtures.h"
#include "devices/codec.h"
#include "devices/lower.h"
#include "image/image_model.h"

namespace contego {
namespace {

using core::Decision;
using core::Reason;

class DevicesThroughCore : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = image::ImageModel{};
    audits_.clear();
    add("gopigo", "gopigo2", 0x08);
    add("line", "line_follower", 0x06);
    add("arm", "pca9685", 0x40);
    model_.tasks.push_back(core::testing::task_rec("t", 200000, 1000, 1, 3));
    model_.access.push_back(core::AccessRecord{0x7, 0x7});
    image_ = image::serialize(model_);
    checker_ = std::make_unique<core::Checker>();
    const core::LoadResult r = checker_->load(image_.data(), static_cast<uint32_t>(image_.size()));
    ASSERT_EQ(r.status, core::LoadStatus::kOk)
        << core::load_status_name(r.status) << " section " << r.section << " record " << r.index;
    checker_->set_host(core::Host{this, nullptr, &DevicesThroughCore::on_audit});
  }

  void add(const char* name, const char* profile, uint16_t addr) {
    devices::DeviceBinding b;
    b.name = name;
    b.addr = addr;
    b.sample_period_us = 10000;
    b.max_sample_age_us = 100000;
    auto id = devices::append_device(model_, *devices::find_builtin_profile(profile), b);
    ASSERT_TRUE(id.ok()) << id.error();
  }

  static void on_audit(void* self, const core::AuditRecord* r) {
    static_cast<DevicesThroughCore*>(self)->audits_.push_back(*r);
  }

  // Sends one write; returns the verdict. audits_ holds its audit records.
  core::Verdict write(uint16_t addr, std::vector<uint8_t> bytes) {
    core::Transaction tx{};
    tx.task = 0;
    tx.bus = 1;
    tx.kind = core::TxKind::kWrite;
    tx.addr = addr;
    tx.job = 1;
    tx.len = static_cast<uint32_t>(bytes.size());
    tx.bytes = bytes.data();
    tx.now_us = now_ += 1000;
    audits_.clear();
    core::Verdict v{};
    checker_->check(tx, &v);
    return v;
  }

  // "name(field=value, ...)" of the last audit record, from the model's names.
  std::string decoded() const {
    if (audits_.empty()) return "(no audit)";
    const core::AuditRecord& a = audits_.back();
    if (a.command == core::kNone) return "(undecoded)";
    const auto& c = model_.commands[a.command];
    std::string s = c.name + "(";
    bool first = true;
    if (c.record.repeat > 1) {
      s += std::to_string(a.index);
      first = false;
    }
    for (uint32_t f = 0; f < a.field_count; ++f) {
      s += (first ? "" : ", ") + model_.fields[c.record.field_first + f].name + "=" +
           std::to_string(a.fields[f]);
      first = false;
    }
    return s + ")";
  }

  image::ImageModel model_;
  std::vector<uint8_t> image_;
  std::unique_ptr<core::Checker> checker_;
  std::vector<core::AuditRecord> audits_;
  uint64_t now_ = 0;
};

TEST_F(DevicesThroughCore, GopigoFramesWithAndWithoutTheRegisterByte) {
  core::Verdict v = write(0x08, {0x01, 0x46, 0x55, 0x00, 0x00});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "set_left_speed(speed=85)");
  v = write(0x08, {0x64, 0x00, 0x00, 0x00});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "right()");
  write(0x08, {0x01, 0x32, 0x03, 0x01, 0x2C});
  EXPECT_EQ(decoded(), "enc_tgt(motors=3, ticks=300)");
  write(0x08, {0x01, 0x50, 0x03, 0xE8, 0x00});
  EXPECT_EQ(decoded(), "enable_com_timeout(timeout=1000)");
}

TEST_F(DevicesThroughCore, GopigoMalformedUnknownAndForbidden) {
  EXPECT_EQ(write(0x08, {0x01, 0x46, 0x55}).reason, Reason::kMalformed);
  EXPECT_EQ(write(0x08, {0x01, 0x46, 0x55, 0, 0, 0}).reason, Reason::kMalformed);
  EXPECT_EQ(write(0x08, {0x01, 0xFE, 0x00, 0x00, 0x00}).reason, Reason::kUnknownCommand);
  core::Verdict v = write(0x08, {0x01, 0x0A, 0x00, 0x00, 0x00});
  EXPECT_EQ(v.reason, Reason::kForbiddenCommand);
  EXPECT_NE(v.decision, Decision::kAllow);
}

TEST_F(DevicesThroughCore, LineFollowerRequestIsAQuery) {
  core::Verdict v = write(0x06, {0x01, 0x03, 0x00, 0x00, 0x00});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "read_sensors()");
}

TEST_F(DevicesThroughCore, Pca9685ByteWiseArmTrace) {
  // Adafruit_PCA9685 (one register per write): hand open, ch5 <- 420.
  EXPECT_EQ(write(0x40, {0x1A, 0x00}).reason, Reason::kStaged);
  EXPECT_EQ(write(0x40, {0x1B, 0x00}).reason, Reason::kStaged);
  EXPECT_EQ(write(0x40, {0x1C, 0xA4}).reason, Reason::kStaged);
  core::Verdict v = write(0x40, {0x1D, 0x01});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "led(5, on=0, off=420, full_on=0, full_off=0)");
  write(0x40, {0xFE, 0x65});
  EXPECT_EQ(decoded(), "prescale(prescale=101)");
}

TEST_F(DevicesThroughCore, Pca9685AutoIncrementFollowsMode1) {
  // Power-on MODE1 0x11 has AI off: a block write to LED5 stays in ON_L,
  // so the group is only staged.
  EXPECT_EQ(write(0x40, {0x1A, 0x00, 0x00, 0x41, 0x02}).reason, Reason::kStaged);
  write(0x40, {0x00, 0xA1});  // RESTART | AI | ALLCALL, as CircuitPython
  core::Verdict v = write(0x40, {0x1A, 0x00, 0x00, 0x41, 0x02});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "led(5, on=0, off=577, full_on=0, full_off=0)");
  // SMBus word write of OFF_L/OFF_H with AI on.
  write(0x40, {0x1C, 0xA4, 0x01});
  EXPECT_EQ(decoded(), "led(5, on=0, off=420, full_on=0, full_off=0)");
}

TEST_F(DevicesThroughCore, Pca9685AllCallAliasReservedAndTestMode) {
  write(0x70, {0x1A, 0x00});
  write(0x70, {0x1B, 0x00});
  write(0x70, {0x1C, 0x41});
  EXPECT_EQ(write(0x70, {0x1D, 0x02}).decision, Decision::kAllow);
  EXPECT_EQ(decoded(), "led(5, on=0, off=577, full_on=0, full_off=0)");
  EXPECT_EQ(write(0x40, {0x46, 0x00}).reason, Reason::kUnknownCommand);
  EXPECT_EQ(write(0x40, {0xF9, 0x00}).reason, Reason::kUnknownCommand);
  EXPECT_EQ(write(0x40, {0xFF, 0x01}).reason, Reason::kForbiddenCommand);
}

TEST_F(DevicesThroughCore, HostEncodingDecodesTheSameInTheCore) {
  // Every built-in actuator command, encoded by the host one register per
  // write, is decoded by the core into the same command and values.
  for (const char* name : {"gopigo", "arm"}) {
    uint16_t dev = 0;
    while (model_.devices[dev].name != name) ++dev;
    const devices::ProfileSpec& p =
        *devices::find_builtin_profile(dev == 0 ? "gopigo2" : "pca9685");
    for (const devices::CommandSpec& c : p.commands) {
      if (c.command_class == core::CommandClass::kForbidden) continue;
      std::vector<devices::FieldValue> values;
      if (c.group_len == 0 && p.kind == core::Profile::kRegisterMap) continue;  // general call
      std::string want = c.name + "(";
      devices::EncodeOptions o;
      o.index = c.repeat > 1 ? c.repeat - 1u : 0u;
      o.per_register = true;
      if (c.repeat > 1) want += std::to_string(o.index);
      for (const devices::FieldSpec& f : c.fields) {
        const int64_t value = f.max - (f.max - f.min) / 3;
        values.push_back({f.name, value});
        want += (want.back() == '(' ? "" : ", ") + f.name + "=" + std::to_string(value);
      }
      want += ")";
      // PRE_SCALE/MODE1 values from this loop may set SLEEP or AI; start clean.
      SetUp();
      auto writes = devices::encode_command(p, c.name, values, o);
      ASSERT_TRUE(writes.ok()) << writes.error();
      core::Verdict v{};
      for (const auto& w : *writes) v = write(model_.devices[dev].record.addr, w);
      EXPECT_EQ(v.decision, Decision::kAllow) << c.name << ": " << core::reason_name(v.reason);
      EXPECT_EQ(decoded(), want);
    }
  }
}

}  // namespace
}  // namespace contego
