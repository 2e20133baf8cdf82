// End-to-end: real, unmodified programs under the seccomp supervisor, with
// the monitor in-process and the virtual bus. A scripted decider stands in
// for a compiled policy so these tests pin the enclave client and monitor
// paths (emulation, fail-closed replies, substitution, safe states) on their
// own. The rules: PCA9685 PRE_SCALE/ALL_LED/TestMode writes and anything to
// the all-call or general-call address are rejected (EPERM); GoPiGo2 speed
// frames above 100 are replaced by speed 80 (FAIL-SAFE); digitalWrite (12) is
// ignored (IGNORE); reads are allowed.
#include "intercept/seccomp/supervisor.h"

#include <stdio.h>
#include <unistd.h>

#include <array>
#include <cstring>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include "bus/virtual_bus.h"
#include "monitor/monitor.h"

namespace contego {
namespace {

class ScriptedDecider final : public monitor::Decider {
 public:
  ScriptedDecider() {
    devices_[0] = {};
    devices_[0].role = core::kRoleActuator;
    devices_[0].bus = 1;
    devices_[0].addr = 0x40;
    devices_[1] = {};
    devices_[1].role = core::kRoleActuator;
    devices_[1].bus = 1;
    devices_[1].addr = 0x08;
    devices_[2] = {};
    devices_[2].role = core::kRoleSensor;
    devices_[2].bus = 1;
    devices_[2].addr = 0x06;
    const uint8_t req[5] = {0x01, 0x03, 0, 0, 0};
    devices_[2].sample_request_len = 5;
    std::memcpy(devices_[2].sample_request, req, 5);
    devices_[2].sample_len = 10;
    devices_[2].sample_period_us = 10000;
  }
  void set_host(const core::Host& host) override { host_ = host; }
  void check(const core::Transaction& tx, core::Verdict* v) override {
    *v = core::Verdict{};
    v->bus = tx.bus;
    v->addr = tx.addr;
    v->device = core::kNone;
    std::vector<uint8_t> bytes(tx.bytes, tx.bytes + tx.len);
    if (tx.kind == core::TxKind::kWrite) {
      if (tx.addr == 0x40 && !bytes.empty() && (bytes[0] == 0xFE || bytes[0] >= 0xFA)) {
        return reject(tx, v);
      }
      if (tx.addr == 0x70 || tx.addr == 0x00) return reject(tx, v);
      if (tx.addr == 0x08 && bytes.size() >= 4) {
        uint8_t* frame = bytes.data() + bytes.size() - 4;
        if (frame[0] == 12) {
          v->decision = core::Decision::kIgnore;
          return audit(tx, *v);
        }
        if ((frame[0] == 70 || frame[0] == 71) && frame[1] > 100) {
          frame[1] = 80;
          v->decision = core::Decision::kFailsafe;
          emit(v, bytes);
          return audit(tx, *v);
        }
      }
      v->decision = core::Decision::kAllow;
      emit(v, bytes);
      return audit(tx, *v);
    }
    v->decision = core::Decision::kAllow;
    audit(tx, *v);
  }
  bool safe_state(uint16_t device, core::Verdict* v) override {
    *v = core::Verdict{};
    v->decision = core::Decision::kFailsafe;
    v->bus = 1;
    v->addr = devices_[device].addr;
    if (device == 1) {
      emit(v, {0x01, 0x78, 0, 0, 0});
      return true;
    }
    if (device == 0) {
      emit(v, {0x1D, 0x10});  // channel 5 full off
      return true;
    }
    return false;
  }
  uint32_t device_count() const override { return 3; }
  const core::DeviceRecord& device(uint16_t id) const override { return devices_[id]; }
  uint32_t task_period_us(uint16_t) const override { return 20000; }

  // The latest sample the monitor handed to the core (via Host::read_sample).
  std::vector<uint8_t> sample(uint16_t device) {
    std::vector<uint8_t> buf(64);
    uint64_t at = 0;
    buf.resize(host_.read_sample(host_.context, device, buf.data(), 64, &at));
    return buf;
  }

 private:
  static void emit(core::Verdict* v, const std::vector<uint8_t>& bytes) {
    v->emit_len[v->emit_count++] = static_cast<uint16_t>(bytes.size());
    std::memcpy(v->emit_bytes + v->emit_bytes_used, bytes.data(), bytes.size());
    v->emit_bytes_used = static_cast<uint16_t>(v->emit_bytes_used + bytes.size());
  }
  void reject(const core::Transaction& tx, core::Verdict* v) {
    v->decision = core::Decision::kReject;
    v->reason = core::Reason::kAccessDenied;
    v->reply_errno = EPERM;
    audit(tx, *v);
  }
  void audit(const core::Transaction& tx, const core::Verdict& v) {
    core::AuditRecord r{};
    r.task = tx.task;
    r.job = tx.job;
    r.decision = v.decision;
    r.reason = v.reason;
    r.bus = tx.bus;
    r.addr = tx.addr;
    r.original = tx.bytes;
    r.original_len = static_cast<uint16_t>(tx.len);
    if (host_.audit != nullptr) host_.audit(host_.context, &r);
  }
  core::Host host_{};
  core::DeviceRecord devices_[3];
};

class Supervised : public ::testing::Test {
 protected:
  void SetUp() override {
    char name[] = "/tmp/contego-audit-XXXXXX";
    const int fd = mkstemp(name);
    ASSERT_GE(fd, 0);
    close(fd);
    audit_path = name;
    ASSERT_TRUE(audit.open(audit_path).ok());
    bus.attach(pca);
    bus.attach(gpg);
    bus.attach(lf);
    mon.add_bus(1, &bus);
  }
  void TearDown() override { unlink(audit_path.c_str()); }

  // Runs argv supervised; stdout of the program is captured.
  intercept::seccomp::RunResult run(std::vector<std::string> argv) {
    fflush(stdout);
    int pipefd[2];
    EXPECT_EQ(pipe(pipefd), 0);
    const int saved = dup(STDOUT_FILENO);
    dup2(pipefd[1], STDOUT_FILENO);
    close(pipefd[1]);
    intercept::seccomp::Options opt;
    opt.task = 0;
    opt.argv = std::move(argv);
    auto r = intercept::seccomp::run(opt, mon);
    fflush(stdout);
    dup2(saved, STDOUT_FILENO);
    close(saved);
    output.clear();
    char buf[4096];
    ssize_t n;
    while ((n = read(pipefd[0], buf, sizeof buf)) > 0) output.append(buf, static_cast<size_t>(n));
    close(pipefd[0]);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
    return r.ok() ? *r : intercept::seccomp::RunResult{};
  }
  std::string audit_text() {
    std::ifstream in(audit_path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  std::string audit_path;
  monitor::AuditLog audit;
  ScriptedDecider decider;
  bus::VirtualBus bus;
  std::shared_ptr<bus::Pca9685> pca = std::make_shared<bus::Pca9685>();
  std::shared_ptr<bus::GoPiGo2> gpg = std::make_shared<bus::GoPiGo2>();
  std::shared_ptr<bus::LineFollower> lf = std::make_shared<bus::LineFollower>();
  monitor::Monitor mon{decider, audit};
  std::string output;
};

TEST_F(Supervised, I2csetAllowedWriteChangesTheDevice) {
  auto r = run({"/usr/sbin/i2cset", "-y", "1", "0x40", "0x06", "0x55"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(pca->reg(0x06), 0x55);
  EXPECT_GT(r.emulated, 0u);
}

TEST_F(Supervised, I2csetDeniedWriteLeavesTheDeviceAndIsAudited) {
  auto r = run({"/usr/sbin/i2cset", "-y", "1", "0x40", "0xfe", "0x03"});
  EXPECT_EQ(r.exit_code, 1);  // "Error: Write failed"
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
  EXPECT_NE(audit_text().find("\"decision\":\"reject\""), std::string::npos);
  EXPECT_NE(audit_text().find("\"bytes\":\"fe 03\""), std::string::npos);
}

TEST_F(Supervised, I2cgetReadsTheRegister) {
  auto r = run({"/usr/sbin/i2cget", "-y", "1", "0x40", "0x00"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(output, "0x11\n");
}

TEST_F(Supervised, I2ctransferFailsafeSubstitutionIsVisibleOnTheDevice) {
  auto r = run({"/usr/sbin/i2ctransfer", "-y", "1", "w5@0x08", "0x01", "0x46", "200", "0", "0"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(gpg->left_speed(), 80);  // 200 requested, 80 substituted
  EXPECT_NE(audit_text().find("\"decision\":\"failsafe\""), std::string::npos);
}

TEST_F(Supervised, I2ctransferSmuggledWriteRefusesTheWholeTransfer) {
  auto r =
      run({"/usr/sbin/i2ctransfer", "-y", "1", "w1@0x40", "0x00", "r1", "w2@0x40", "0xfe", "0x03"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
}

TEST_F(Supervised, I2cdetectSeesTheVirtualDevices) {
  auto r = run({"/usr/sbin/i2cdetect", "-y", "1"});
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(output.find("40 "), std::string::npos) << output;
  EXPECT_NE(output.find("08 "), std::string::npos) << output;
  EXPECT_NE(output.find("70"), std::string::npos) << output;  // all-call answers too
  EXPECT_EQ(output.find("41 "), std::string::npos) << output;
}

TEST_F(Supervised, PythonSmbusReplaysTheGoPiGoSequence) {
  auto r = run({"/usr/bin/python3", CONTEGO_SCRIPTS_DIR "/gopigo_smbus.py"});
  EXPECT_EQ(r.exit_code, 0) << output;
  EXPECT_EQ(gpg->left_speed(), 80);  // set_speed(150) substituted
  EXPECT_EQ(gpg->right_speed(), 80);
  EXPECT_EQ(gpg->frames(), 5u);    // 70, 71, 105, 114 and the exit stop; 12 was ignored
  EXPECT_EQ(gpg->motion(), 0x78);  // stopped by the safe state when the task exited
  EXPECT_NE(output.find("speeds 80 80"), std::string::npos) << output;
  EXPECT_NE(output.find("digitalWrite ignored"), std::string::npos) << output;
}

TEST_F(Supervised, PythonSmbus2ReplaysThePca9685Sequence) {
  auto r = run({"/usr/bin/python3", CONTEGO_SCRIPTS_DIR "/pca9685_smbus2.py"});
  EXPECT_EQ(r.exit_code, 0) << output;
  EXPECT_NE(output.find("off 577"), std::string::npos) << output;
  EXPECT_EQ(pca->reg(0x1C), 0x41);
  EXPECT_EQ(pca->reg(0x1D), 0x10);  // channel 5 full off: the safe state after the task exited
  EXPECT_EQ(pca->reg(0xFE), 0x1E);  // the PRE_SCALE write was refused
  EXPECT_NE(output.find("prescale refused"), std::string::npos) << output;
}

TEST_F(Supervised, BufferRewrittenByASecondThreadNeverReachesTheBus) {
  auto r = run({CONTEGO_TESTCASES_DIR "/attack_rdwr_race"});
  EXPECT_EQ(r.exit_code, 0) << output;
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
  EXPECT_EQ(pca->reg(0x06), 0x10);
}

TEST_F(Supervised, StaticBinaryAttacksChangeNothingForbidden) {
  auto r = run({CONTEGO_TESTCASES_DIR "/attack_static"});
  EXPECT_NE(output.find("open-other-path "), std::string::npos) << output;
  EXPECT_EQ(output.find("open-other-path -1"), std::string::npos) << output;  // got a descriptor
  EXPECT_NE(output.find("slave-force 0 0"), std::string::npos) << output;
  EXPECT_NE(output.find("write-prescale -1 1"), std::string::npos) << output;  // EPERM
  EXPECT_NE(output.find("raw-write-prescale -1 1"), std::string::npos) << output;
  EXPECT_NE(output.find("write-allcall -1 1"), std::string::npos) << output;
  EXPECT_NE(output.find("rdwr-smuggle -1 1"), std::string::npos) << output;
  EXPECT_NE(output.find("dup2-out -1 1"), std::string::npos) << output;
  EXPECT_NE(output.find("write-prescale-copy -1 1"), std::string::npos) << output;
  EXPECT_NE(output.find("fork-child-denied 0"), std::string::npos) << output;
  EXPECT_EQ(r.exit_code, 1);  // the exec'd i2cset was refused too
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
  for (int ch = 0; ch < 16; ++ch) EXPECT_EQ(pca->led_off(ch), 0x1000) << ch;
}

TEST_F(Supervised, TaskExitDrivesTheSafeState) {
  run({"/usr/sbin/i2cset", "-y", "1", "0x08", "0x01", "0x77", "0", "0", "0", "i"});
  EXPECT_EQ(gpg->motion(), 0x78);  // fwd was allowed, then the exit stopped the rover
  EXPECT_EQ(gpg->frames(), 2u);
  EXPECT_NE(audit_text().find("safe-state"), std::string::npos);
}

TEST_F(Supervised, MonitorSamplesSensorsItself) {
  lf->set_values({1, 2, 3, 4, 1023});
  mon.sample_all();
  auto s = decider.sample(2);
  ASSERT_EQ(s.size(), 10u);
  EXPECT_EQ(s[9], 0xFF);
  EXPECT_EQ(s[8], 0x03);
}

TEST_F(Supervised, ProgramThatDoesNotExistFailsCleanly) {
  auto r = run({"/nonexistent/program"});
  EXPECT_EQ(r.exit_code, 127);
}

}  // namespace
}  // namespace contego
