// End-to-end with the real trusted core: the example policies compiled by the
// policy compiler, loaded into core::Checker, and unmodified programs
// (i2c-tools, python3 with smbus/smbus2) under every enclave client against
// the virtual bus. Allowed commands change the device; denied ones leave it
// untouched and are audited; a FAIL-SAFE substitution is visible on the device.
#include <stdlib.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <gtest/gtest.h>
#include <iostream>
#include <map>
#include <sstream>
#include <sys/wait.h>
#include <thread>

#include "bus/virtual_bus.h"
#include "gate/socket.h"
#include "gate/socket_client.h"
#include "intercept/seccomp/supervisor.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "monitor/server.h"
#include "policy/compile.h"
#include "test_support.h"

namespace contego {
namespace {

enum class Client { kInProcess, kSocket, kPreload };
constexpr const char* kClientNames[] = {"seccomp_in_process", "seccomp_socket", "preload_socket"};

class PolicyE2e : public ::testing::TestWithParam<Client> {
 protected:
  void load(const std::string& policy_name) {
    ASSERT_NO_FATAL_FAILURE(
        test_support::open_temp_audit(audit, &audit_path, "/tmp/contego-policy-audit-XXXXXX"));
    policy::CompileOutput out;
    ASSERT_NO_FATAL_FAILURE(test_support::load_policy(
        std::string(CONTEGO_POLICIES_DIR) + "/" + policy_name, decider, &out));
    std::vector<std::string> names;
    for (size_t i = 0; i < out.model.tasks.size(); ++i) {
      tasks[out.model.tasks[i].name] = static_cast<uint16_t>(i);
      names.push_back(out.model.tasks[i].name);
    }
    bus.attach(pca);
    bus.attach(gpg);
    bus.attach(lf);
    lf->set_values({767, 815, 1015, 710, 700});  // the line under the middle sensor: pos 0
    mon = std::make_unique<monitor::Monitor>(decider, audit);
    mon->set_task_names(names);
    mon->add_bus(1, &bus);
    mon->sample_all();
    mon->start_sampling();  // invariants refuse stale samples (max_age)
    if (GetParam() != Client::kInProcess) {
      socket_path = "/tmp/contego-policy-" + std::to_string(getpid()) + ".sock";
      server = std::make_unique<monitor::Server>(*mon, audit, tasks, std::set<uid_t>{getuid()});
      ASSERT_TRUE(server->listen(socket_path).ok());
      server_thread = std::thread([this] { server->serve(); });
    }
  }
  void TearDown() override {
    test_support::stop_server(server.get(), server_thread);
    if (HasFailure()) std::cerr << "audit log:\n" << audit_text();
    if (!audit_path.empty()) unlink(audit_path.c_str());
  }

  int run(const std::string& task, std::vector<std::string> argv) {
    fflush(stdout);
    int pipefd[2];
    EXPECT_EQ(pipe(pipefd), 0);
    const int saved = dup(STDOUT_FILENO);
    dup2(pipefd[1], STDOUT_FILENO);
    close(pipefd[1]);
    int code = -1;
    if (GetParam() == Client::kPreload) {
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      const pid_t pid = fork();
      if (pid == 0) {
        // A program of its own, as a shell starts a command (its own process
        // group): its exit ends its session (contego/session_room.h).
        setpgid(0, 0);
        setenv("LD_PRELOAD", CONTEGO_PRELOAD_LIB, 1);
        setenv("CONTEGO_SOCKET", socket_path.c_str(), 1);
        setenv("CONTEGO_TASK", task.c_str(), 1);
        execv(args[0], args.data());
        _exit(127);
      }
      int status = 0;
      waitpid(pid, &status, 0);
      code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    } else {
      intercept::seccomp::Options opt;
      opt.argv = std::move(argv);
      std::unique_ptr<gate::SocketClient> client;
      gate::Endpoint* endpoint = mon.get();
      opt.task = tasks.at(task);
      if (GetParam() == Client::kSocket) {
        auto c = gate::SocketClient::connect(socket_path, task);
        EXPECT_TRUE(c.ok());
        if (c.ok()) client = std::move(*c);
        endpoint = client.get();
      }
      auto r = intercept::seccomp::run(opt, *endpoint);
      EXPECT_TRUE(r.ok());
      code = r.ok() ? r->exit_code : -1;
    }
    fflush(stdout);
    dup2(saved, STDOUT_FILENO);
    close(saved);
    output.clear();
    char buf[4096];
    ssize_t n;
    while ((n = read(pipefd[0], buf, sizeof buf)) > 0) output.append(buf, static_cast<size_t>(n));
    close(pipefd[0]);
    if (GetParam() != Client::kInProcess) {
      // The monitor learns of the exit from the closed connection, on its own thread.
      for (int i = 0; i < 200 && audit_text().find("safe-state") == std::string::npos; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
    (void)mon->has_bus(1);  // orders the reads of the models after the monitor's writes
    return code;
  }
  std::string audit_text() { return test_support::file_text(audit_path); }

  std::string audit_path, socket_path, output;
  monitor::AuditLog audit;
  monitor::CoreDecider decider;
  bus::VirtualBus bus;
  std::shared_ptr<bus::Pca9685> pca = std::make_shared<bus::Pca9685>();
  std::shared_ptr<bus::GoPiGo2> gpg = std::make_shared<bus::GoPiGo2>();
  std::shared_ptr<bus::LineFollower> lf = std::make_shared<bus::LineFollower>();
  std::unique_ptr<monitor::Monitor> mon;
  std::map<std::string, uint16_t> tasks;
  std::unique_ptr<monitor::Server> server;
  std::thread server_thread;
};

TEST_P(PolicyE2e, RoverI2ctransferExpectedSpeedIsAllowed) {
  load("rover.policy");
  EXPECT_EQ(run("follower",
                {"/usr/sbin/i2ctransfer", "-y", "1", "w5@0x08", "0x01", "70", "80", "0", "0"}),
            0)
      << output;
  EXPECT_EQ(gpg->left_speed(), 80);
  EXPECT_NE(audit_text().find("\"decision\":\"allow\""), std::string::npos);
}

TEST_P(PolicyE2e, RoverI2ctransferWrongSpeedIsReplacedByTheExpectedOne) {
  load("rover.policy");
  EXPECT_EQ(run("follower",
                {"/usr/sbin/i2ctransfer", "-y", "1", "w5@0x08", "0x01", "70", "200", "0", "0"}),
            0)
      << output;
  EXPECT_EQ(gpg->left_speed(), 80);  // FAIL-SAFE: 200 asked, the expected 80 sent
  EXPECT_NE(audit_text().find("\"decision\":\"failsafe\""), std::string::npos);
}

TEST_P(PolicyE2e, RoverI2csetOnADeviceTheTaskMayNotUseChangesNothing) {
  load("rover.policy");
  EXPECT_NE(run("follower", {"/usr/sbin/i2cset", "-y", "1", "0x40", "0x06", "0x55"}), 0);
  EXPECT_EQ(pca->reg(0x06), 0x00);
  EXPECT_NE(audit_text().find("\"decision\":\"reject\""), std::string::npos);
}

TEST_P(PolicyE2e, RoverI2cgetOfADeviceOutsideThePolicyIsARefusedRead) {
  // The follower may read the line sensor and the motor controller (the
  // vendor library's status queries), nothing else.
  load("rover.policy");
  EXPECT_NE(run("follower", {"/usr/sbin/i2cget", "-y", "1", "0x40"}), 0) << output;
  EXPECT_NE(audit_text().find("\"decision\":\"reject\""), std::string::npos);
}

TEST_P(PolicyE2e, RoverPythonSmbusFailsafeThenForbiddenCommandRefused) {
  load("rover.policy");
  EXPECT_EQ(run("follower", {"/usr/bin/python3", CONTEGO_SCRIPTS_DIR "/rover_follower_smbus.py"}),
            0)
      << output;
  EXPECT_NE(output.find("job 1 sent"), std::string::npos) << output;
  EXPECT_NE(output.find("digital_write refused"), std::string::npos) << output;
  EXPECT_EQ(gpg->left_speed(), 80);
  EXPECT_EQ(gpg->right_speed(), 80);
  EXPECT_EQ(gpg->motion(), 0x78);  // the safe state stop() when the task ended
}

// rover.policy declares 3 actuations per 100 ms job for the follower; past
// its rate limit (3 per job, else ignore) every frame is ignored, not
// performed, and spends nothing of the rate. Dropped transfers have their own
// budget (here factor 2 x max(3, 8) = 16 per job, so that a slow machine
// still sends more than that in 100 ms; the acting budget, 2 x 3, is never
// reached): a loop that never sleeps has its 17th dropped frame of a job
// held to the next release. Every job then has its three frames act and at
// most 17 dropped.
TEST_P(PolicyE2e, RoverBurstIsHeldToItsBudgetPerPeriod) {
  load("rover.policy");
  mon->set_budget_factor(2);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(run("follower", {"/usr/bin/python3", CONTEGO_SCRIPTS_DIR "/rover_burst.py", "120"}), 0)
      << output;
  const auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_NE(output.find("sent 120"), std::string::npos) << output;
  EXPECT_GE(mon->holds(), 1u);
  EXPECT_GE(elapsed, std::chrono::milliseconds(100));
  const std::string log = audit_text();
  EXPECT_NE(log.find("over its budget of 16 transfers that did not act per job"),
            std::string::npos);
  std::map<int, int> acted, dropped;  // per job
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    const size_t at = line.find("\"job\":");
    if (line.find("\"kind\":\"decision\"") == std::string::npos || at == std::string::npos) {
      continue;
    }
    const int job = std::stoi(line.substr(at + 6));
    ++(line.find("\"decision\":\"allow\"") != std::string::npos ? acted : dropped)[job];
  }
  ASSERT_FALSE(acted.empty());
  for (const auto& [job, n] : acted) EXPECT_LE(n, 3) << "job " << job;
  for (const auto& [job, n] : dropped) EXPECT_LE(n, 17) << "job " << job;
  // Each held job's first three frames acted, whatever the dropped ones did.
  for (const auto& [job, n] : dropped) {
    if (n == 17) {
      EXPECT_EQ(acted[job], 3) << "job " << job;
    }
  }
}

TEST_P(PolicyE2e, ArmGripperPythonSmbus2PulseAllowedPrescaleDropped) {
  load("arm.policy");
  // What arm_init leaves behind: awake, register auto-increment on.
  uint8_t mode1[2] = {0x00, 0x21};
  bus::Msg m{0x40, 0, 2, mode1};
  ASSERT_EQ(bus.transfer({&m, 1}), 0);
  EXPECT_EQ(run("gripper", {"/usr/bin/python3", CONTEGO_SCRIPTS_DIR "/gripper_smbus2.py"}), 0)
      << output;
  EXPECT_NE(output.find("pulse sent"), std::string::npos) << output;
  // The gripper's configuration writes are dropped, the program told they
  // succeeded (the vendor constructor must not fail): the prescale is as it was.
  EXPECT_NE(output.find("prescale written"), std::string::npos) << output;
  // The pulse was allowed (audited as such); when the task ended the monitor
  // drove the gripper channel to the policy's per-channel safe state, open at
  // 420 with the full-off bit cleared (before arm.policy had a safe state the
  // channel kept its power-on full off, 0x1000).
  EXPECT_NE(audit_text().find("\"bytes\":\"1a 00 00 a4 01\",\"command\":6,\"decision\":\"allow\""),
            std::string::npos);
  EXPECT_NE(audit_text().find("safe-state"), std::string::npos);
  EXPECT_EQ(pca->led_on(5), 0);
  EXPECT_EQ(pca->led_off(5), 420);
  EXPECT_EQ(pca->reg(0xFE), 0x1E);  // PRE_SCALE untouched
}

// issue 11: a combined transfer whose second message is refused acts
// nothing and leaves the core's model of the chip as it was; a general call
// (every PCA9685 takes `06 ...` as a software reset), a reserved address and
// an undeclared 10-bit address act nothing. The device read back and the
// core's register shadow agree afterwards.
TEST_P(PolicyE2e, ArmAttackCombinedTransferGeneralCallAndReservedAddressesActNothing) {
  load("arm.policy");
  // What arm_init leaves behind: awake, register auto-increment on (the
  // device and the core's shadow, as `contego` seeds it at start).
  uint8_t mode1[2] = {0x00, 0x21};
  bus::Msg m{0x40, 0, 2, mode1};
  ASSERT_EQ(bus.transfer({&m, 1}), 0);
  ASSERT_TRUE(decider.checker().seed_register(0, 0x00, 0x21));
  // The monitor's threads read the core under the monitor's mutex: taking it
  // once publishes the seeded shadow to them (the server is already running).
  (void)mon->job(0);
  const uint8_t led3_off_l = pca->reg(0x06 + 4 * 3 + 2);
  ASSERT_NE(led3_off_l, 0x2C);
  EXPECT_EQ(run("gripper", {CONTEGO_TESTCASES_DIR "/attack_rdwr_atomic"}), 0) << output;
  // arm.policy ignores the gripper's configuration writes (a vendor
  // constructor must run), so each transfer is ignored as a whole: the call
  // reports success and nothing of it acts (checked below).
  EXPECT_NE(output.find("rdwr-led3-prescale 2 0\n"), std::string::npos) << output;
  EXPECT_NE(output.find("rdwr-grip-prescale 2 0\n"), std::string::npos) << output;
  EXPECT_NE(output.find("general-call 1 0\n"), std::string::npos) << output;  // ignored
  EXPECT_NE(output.find("reserved -1 6\n"), std::string::npos) << output;     // ENXIO
  EXPECT_NE(output.find("ten-bit -1 "), std::string::npos) << output;
  EXPECT_NE(output.find("pulse 5 0\n"), std::string::npos) << output;
  // Nothing of the refused transfers acted: channel 3 and PRE_SCALE as they
  // were, no software reset (MODE1 still awake with auto-increment).
  EXPECT_EQ(pca->reg(0x06 + 4 * 3 + 2), led3_off_l);
  EXPECT_EQ(pca->reg(0xFE), 0x1E);
  EXPECT_EQ(pca->reg(0x00), 0x21);
  const std::string log = audit_text();
  // Reasons by number: 28 transfer-dropped, 26 general-call, 27 reserved-address.
  EXPECT_NE(log.find("\"kind\":\"decision\",\"reason\":28"), std::string::npos);
  EXPECT_NE(log.find("\"bytes\":\"06 00 00 77 01\",\"command\":65535,\"decision\":\"ignore\""),
            std::string::npos);
  EXPECT_NE(log.find("\"reason\":26"), std::string::npos);
  EXPECT_NE(log.find("\"reason\":27"), std::string::npos);
  // The pulse after the refused transfer was the sequence's first step,
  // allowed as sent: the refused 420 did not move the sequence on (it would
  // have been replaced by the expected 577).
  EXPECT_NE(log.find("\"bytes\":\"1a 00 00 a4 01\",\"command\":6,\"decision\":\"allow\""),
            std::string::npos);
  EXPECT_EQ(log.find("\"decision\":\"failsafe\""), std::string::npos);
  // The core's model agrees with the device, register by register.
  for (int r = 0; r < 256; ++r) {
    if (r >= 0x46 && r < 0xFA) continue;  // reserved registers: no command, never written
    uint8_t shadow = 0;
    ASSERT_TRUE(decider.checker().shadow(0, static_cast<uint8_t>(r), &shadow));
    EXPECT_EQ(shadow, pca->reg(static_cast<uint8_t>(r))) << "register 0x" << std::hex << r;
  }
}

// A task that may read the arm sends reads and writes with i2c_msg flags
// outside the allow-list (contego/i2c_msg_flags.h): protocol mangling that
// on a bit-banged adapter makes a checked read act as a write. Every client
// refuses each with EINVAL before the checker or the bus sees it; a plain
// read still works; the chip is unchanged and nothing was decided.
TEST_P(PolicyE2e, ArmReadsWithProtocolManglingFlagsAreRefusedAtEveryClient) {
  load("arm.policy");
  uint8_t mode1[2] = {0x00, 0x21};
  bus::Msg m{0x40, 0, 2, mode1};
  ASSERT_EQ(bus.transfer({&m, 1}), 0);
  EXPECT_EQ(run("gripper", {CONTEGO_TESTCASES_DIR "/attack_msg_flags"}), 0) << output;
  for (const char* flag :
       {"nostart", "rev-dir-addr", "ignore-nak", "no-rd-ack", "stop", "dma-safe", "unknown"}) {
    for (const char* step : {"read-", "lone-read-", "write-"}) {
      const std::string line = std::string(step) + flag + " -1 22\n";
      EXPECT_NE(output.find(line), std::string::npos) << line << output;
    }
  }
  EXPECT_NE(output.find("read-plain 2 0\nmode1 0x21\n"), std::string::npos) << output;
  EXPECT_EQ(pca->reg(0xFF), 0);
  EXPECT_EQ(pca->reg(0x00), 0x21);
  // Refused before the checker: nothing of them was decided.
  const std::string log = audit_text();
  EXPECT_EQ(log.find("\"decision\":\"ignore\""), std::string::npos);
  EXPECT_EQ(log.find("\"bytes\":\"ff ff\""), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Clients, PolicyE2e,
                         ::testing::Values(Client::kInProcess, Client::kSocket, Client::kPreload),
                         test_support::enum_param_names(kClientNames));

}  // namespace
}  // namespace contego
