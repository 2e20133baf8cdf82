// `contego reload` racing the traffic it must not disturb (issue 36): the
// daemon's reloader (cli/policy_reload.h) swaps two policies back and forth
// while a task's thread keeps sending servo pulses through the real monitor
// and core on a virtual bus. Every transfer gets one answer from one policy,
// every reload is recorded with both hashes, the sequence invariant's
// position survives every swap, and a reload that must be refused leaves the
// running policy in force. Built for the ThreadSanitizer stage (label monitor).
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <string>
#include <thread>

#include "base/test_temp.h"
#include "bundle/bundle.h"
#include "cli/policy_load.h"
#include "cli/policy_reload.h"
#include "gate/transfer.h"
#include "monitor/server.h"

namespace contego::cli {
namespace {

const std::string kArm = std::string(CONTEGO_POLICIES_DIR) + "/arm.policy";

class ReloadRace : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("contego-reload", &dir_));
    std::ifstream in(kArm);
    std::stringstream text;
    text << in.rdbuf();
    const std::string a = text.str();
    std::string b = a;
    const std::string from = "const SERVO_MAX = 600", to = "const SERVO_MAX = 580";
    ASSERT_NE(b.find(from), std::string::npos);
    b.replace(b.find(from), from.size(), to);
    std::ofstream(dir_ + "/a.policy") << a;
    std::ofstream(dir_ + "/b.policy") << b;
    options_.policy = dir_ + "/a.policy";
    options_.audit = dir_ + "/audit.jsonl";
    options_.virtual_buses = {1};
    auto t = monitor::setup(options_);
    ASSERT_TRUE(t.ok()) << t.error();
    trusted_ = std::move(*t);
    server_ = std::make_unique<monitor::Server>(*trusted_->monitor, trusted_->audit,
                                                trusted_->tasks, std::set<uid_t>{getuid()});
    reloader_ = make_reloader(options_, *trusted_, *server_, nullptr);
  }
  void TearDown() override {
    server_.reset();
    trusted_.reset();
    for (const char* f : {"/a.policy", "/b.policy", "/audit.jsonl"}) unlink((dir_ + f).c_str());
    rmdir(dir_.c_str());
  }
  std::string bundle_text(const std::string& policy) {
    monitor::SetupOptions o;
    o.policy = policy;
    auto loaded = monitor::load_policy(o);
    EXPECT_TRUE(loaded.ok()) << loaded.error();
    return bundle::encode_bundle(monitor::bundle_of(*loaded, policy));
  }
  // One servo pulse on `channel` as the Adafruit library writes it with
  // auto-increment off: four byte writes, the group acting on the last.
  int pulse(uint16_t task, uint8_t channel, uint16_t off) {
    const auto base = static_cast<uint8_t>(6 + 4 * channel);
    const uint8_t values[4] = {0, 0, static_cast<uint8_t>(off & 0xFF),
                               static_cast<uint8_t>(off >> 8)};
    for (uint8_t k = 0; k < 4; ++k) {
      gate::Transfer t;
      t.bus = 1;
      gate::Message m;
      m.addr = 0x40;
      m.len = 2;
      m.data = {static_cast<uint8_t>(base + k), values[k]};
      t.messages.push_back(m);
      if (int err = trusted_->monitor->transfer(task, t).err; err != 0) return err;
    }
    return 0;
  }
  std::string audit() const {
    std::ifstream in(options_.audit);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  std::string dir_;
  monitor::SetupOptions options_;
  std::unique_ptr<monitor::Trusted> trusted_;
  std::unique_ptr<monitor::Server> server_;
  monitor::Server::Reloader reloader_;
};

TEST_F(ReloadRace, ReloadsBetweenTransfersKeepEveryAnswer) {
  const std::string a = bundle_text(dir_ + "/a.policy");
  const std::string b = bundle_text(dir_ + "/b.policy");
  const uint16_t gripper = trusted_->tasks.at("gripper");
  trusted_->monitor->set_budget_factor(0);  // the test sends far above the policy's rate
  std::atomic<bool> stop{false};
  std::atomic<int> failures{0}, pulses{0};
  std::thread traffic([&] {
    while (!stop.load()) {
      if (pulse(gripper, 0, 300) != 0) ++failures;
      ++pulses;
    }
  });
  int reloads = 0;
  for (int i = 0; i < 20; ++i) {
    const auto answer = reloader_({i % 2 == 0 ? b : a, ""}, getuid());
    ASSERT_EQ(answer.err, 0) << answer.text;
    ++reloads;
  }
  stop.store(true);
  traffic.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_GT(pulses.load(), 0);
  const std::string log = audit();
  size_t n = 0;
  for (size_t at = log.find("\"kind\":\"reload\""); at != std::string::npos;
       at = log.find("\"kind\":\"reload\"", at + 1)) {
    ++n;
  }
  EXPECT_EQ(n, static_cast<size_t>(reloads));
}

TEST_F(ReloadRace, TheGripperSequenceSurvivesAReload) {
  const uint16_t gripper = trusted_->tasks.at("gripper");
  ASSERT_EQ(pulse(gripper, 5, 420), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(1050));  // `1 per job` of 1 s
  const auto answer = reloader_({bundle_text(dir_ + "/b.policy"), ""}, getuid());
  ASSERT_EQ(answer.err, 0) << answer.text;
  ASSERT_EQ(pulse(gripper, 5, 577), 0);  // the next job: the close the sequence expects
  const std::string log = audit();
  const size_t reload = log.find("\"kind\":\"reload\"");
  ASSERT_NE(reload, std::string::npos);
  // After the reload, the 577 group was allowed, not replaced by the expected 420.
  EXPECT_NE(
      log.find("\"decision\":\"allow\",\"device\":0,\"device_name\":\"arm\",\"fields\":[0,577",
               reload),
      std::string::npos)
      << log.substr(reload);
}

TEST_F(ReloadRace, ARefusedReloadLeavesThePolicyInForce) {
  const std::string before = trusted_->image_sha256;
  const std::string unsigned_bundle = bundle_text(dir_ + "/a.policy");
  // Not a bundle at all, then a bundle that is not signed under --require-signed.
  auto answer = reloader_({"{\"format\": 1}", ""}, getuid());
  EXPECT_NE(answer.err, 0);
  options_.require_signed = true;
  answer = reloader_({unsigned_bundle, ""}, getuid());
  EXPECT_NE(answer.err, 0);
  EXPECT_NE(answer.text.find("no signature"), std::string::npos) << answer.text;
  EXPECT_EQ(trusted_->image_sha256, before);
  EXPECT_EQ(audit().find("\"kind\":\"reload\""), std::string::npos);
}

}  // namespace
}  // namespace contego::cli
