// contego.ko's audit records (kernel/contego_kmod.h) as `contego kmod audit`
// writes them: every record type becomes one chained line of the audit log,
// with the policy's names beside the numbers; the bytes kept by the module
// are what the line shows, never more.
#include "cli/kmod_audit.h"

#include <time.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "contego/core_c.h"
#include "contego/i2c_plan.h"

#include "base/test_temp.h"
#include "bus/smbus_plan.h"
#include "cli/kmod_status.h"
#include "cli/policy_load.h"
#include "cli/trusted_setup.h"

namespace contego::cli {
namespace {

class KmodAudit : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_file("contego-kmod-audit", &path_));
    monitor::SetupOptions o;
    o.policy = std::string(CONTEGO_POLICIES_DIR) + "/arm.policy";
    auto loaded = monitor::load_policy(o);
    ASSERT_TRUE(loaded.ok()) << loaded.error();
    names_ = monitor::name_table(loaded->model);
    ASSERT_TRUE(log_.open(path_).ok());
  }
  void TearDown() override { unlink(path_.c_str()); }

  std::vector<nlohmann::json> lines() {
    std::ifstream in(path_);
    std::vector<nlohmann::json> out;
    for (std::string line; std::getline(in, line);) {
      if (!line.empty() && line[0] == '{') out.push_back(nlohmann::json::parse(line));
    }
    return out;
  }

  std::string path_;
  monitor::NameTable names_;
  monitor::AuditLog log_;
};

contego_kmod_record record(uint8_t type) {
  contego_kmod_record r{};
  r.type = type;
  r.seq = 1;
  r.task = r.device = r.command = r.rule = CONTEGO_NONE;
  return r;
}

TEST_F(KmodAudit, DecisionCarriesTheNamesAndTheKeptBytes) {
  contego_kmod_record r = record(CONTEGO_KMOD_REC_DECISION);
  r.task = 1;  // gripper
  r.device = 0;
  r.command = 0;
  r.decision = 2;  // failsafe
  r.job = 7;
  r.bus = 1;
  r.addr = 0x40;
  r.field_count = 2;
  r.fields[0] = 0;
  r.fields[1] = 900;
  r.original_len = 40;  // longer than the module keeps
  for (uint8_t i = 0; i < CONTEGO_KMOD_REC_BYTES; ++i) r.original[i] = i;
  r.substitute_len = 5;
  r.substitute[0] = 0x1a;
  r.pid = 42;
  // Taken by the module two seconds ago (its CLOCK_MONOTONIC): the line
  // carries that instant, not the time it is written.
  timespec mono{}, wall{};
  clock_gettime(CLOCK_MONOTONIC, &mono);
  clock_gettime(CLOCK_REALTIME, &wall);
  const auto us = [](const timespec& t) {
    return static_cast<uint64_t>(t.tv_sec) * 1000000u + static_cast<uint64_t>(t.tv_nsec) / 1000u;
  };
  r.time_us = us(mono) - 2000000;
  ASSERT_TRUE(write_kmod_record(log_, names_, r));
  auto l = lines();
  ASSERT_EQ(l.size(), 1u);
  EXPECT_EQ(l[0]["kind"], "decision");
  EXPECT_EQ(l[0]["decision"], "failsafe");
  EXPECT_EQ(l[0]["task_name"], names_.tasks[1]);
  EXPECT_EQ(l[0]["device_name"], names_.devices[0]);
  EXPECT_EQ(l[0]["job"], 7);
  EXPECT_EQ(l[0]["fields"][1], 900);
  // Space-separated hex: three characters a byte, less the last space.
  EXPECT_EQ(l[0]["bytes"].get<std::string>().size(), 3u * CONTEGO_KMOD_REC_BYTES - 1);
  EXPECT_EQ(l[0]["substitute"], "1a 00 00 00 00");
  EXPECT_EQ(l[0]["pid"], 42);
  EXPECT_EQ(l[0]["uid"], 0);
  EXPECT_EQ(l[0]["mono_us"].get<uint64_t>(), r.time_us);
  const int64_t t = l[0]["t_us"].get<int64_t>();
  const int64_t expected = static_cast<int64_t>(us(wall)) - 2000000;
  EXPECT_LT(std::llabs(t - expected), 500000) << t << " vs " << expected;
}

TEST_F(KmodAudit, EventsNameDeviceCallerAndGap) {
  contego_kmod_record s = record(CONTEGO_KMOD_REC_SAFE_STATE);
  s.device = 0;
  s.bus = 1;
  s.addr = 0x40;
  s.why = CONTEGO_KMOD_SAFE_UNRECORDED | CONTEGO_KMOD_SAFE_FAILED;
  s.pid = 99;
  s.uid = 1000;
  contego_kmod_record g = record(CONTEGO_KMOD_REC_GAP);
  g.count = 12;
  contego_kmod_record ld = record(CONTEGO_KMOD_REC_LOAD);
  ld.count = 4096;
  contego_kmod_record bad = record(CONTEGO_KMOD_REC_LOAD_REFUSED);
  bad.reason = 3;
  contego_kmod_record odd = record(200);
  for (const auto* r : {&s, &g, &ld, &bad, &odd}) ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  auto l = lines();
  ASSERT_EQ(l.size(), 5u);
  const std::string safe = l[0]["detail"];
  EXPECT_EQ(l[0]["kind"], "safe-state");
  EXPECT_NE(safe.find(names_.devices[0]), std::string::npos) << safe;
  EXPECT_NE(safe.find("failing closed"), std::string::npos) << safe;
  EXPECT_NE(safe.find("pid 99 uid 1000"), std::string::npos) << safe;
  EXPECT_NE(safe.find("FAILED"), std::string::npos) << safe;
  EXPECT_EQ(l[1]["kind"], "audit-gap");
  EXPECT_NE(l[1]["detail"].get<std::string>().find("12 record(s)"), std::string::npos);
  EXPECT_EQ(l[2]["kind"], "policy-load");
  EXPECT_EQ(l[3]["kind"], "policy-load-refused");
  EXPECT_EQ(l[4]["kind"], "fault");
  // One chain: `contego audit` verifies it.
  std::ifstream in(path_);
  const monitor::AuditCheck c = monitor::verify_audit(in);
  EXPECT_TRUE(c.ok) << c.error;
}

// A session's end (a bound process exited): the task, the process, how it
// ended, and each actuator driven -- the monitor's "task N exited".
TEST_F(KmodAudit, SessionEndNamesTaskProcessAndHowItEnded) {
  contego_kmod_record killed = record(CONTEGO_KMOD_REC_SAFE_STATE);
  killed.why = CONTEGO_KMOD_SAFE_EXIT;
  killed.task = 1;  // gripper
  killed.device = 0;
  killed.bus = 1;
  killed.addr = 0x40;
  killed.pid = 321;
  killed.uid = 990;
  killed.count = 9;  // wait status: killed by SIGKILL
  killed.substitute_len = 5;
  killed.substitute[0] = 0x1a;
  contego_kmod_record script = killed;
  script.count = 0;  // exit 0, ended with its process group's leader
  script.index = 1;
  script.why |= CONTEGO_KMOD_SAFE_FAILED;
  contego_kmod_record none = record(CONTEGO_KMOD_REC_SAFE_STATE);
  none.why = CONTEGO_KMOD_SAFE_EXIT;
  none.task = 0;
  none.pid = 7;
  none.count = 3 << 8;  // exit status 3
  for (const auto* r : {&killed, &script, &none}) {
    ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  }
  auto l = lines();
  ASSERT_EQ(l.size(), 3u);
  const std::string a = l[0]["detail"], b = l[1]["detail"], c = l[2]["detail"];
  EXPECT_EQ(l[0]["kind"], "safe-state");
  EXPECT_NE(a.find("task 1 (" + names_.tasks[1] + ") exited: pid 321 uid 990 killed by signal 9"),
            std::string::npos)
      << a;
  EXPECT_NE(a.find("device 0 (" + names_.devices[0] + ")"), std::string::npos) << a;
  EXPECT_NE(a.find("[1a 00 00 00 00]"), std::string::npos) << a;
  EXPECT_EQ(a.find("FAILED"), std::string::npos) << a;
  EXPECT_NE(b.find("exited with status 0, then its process group's leader exited"),
            std::string::npos)
      << b;
  EXPECT_NE(b.find("FAILED"), std::string::npos) << b;
  EXPECT_NE(c.find("task 0 (" + names_.tasks[0] + ") exited: pid 7 uid 0 exited with status 3"),
            std::string::npos)
      << c;
  EXPECT_NE(c.find("none of its actuators has a safe state"), std::string::npos) << c;
}

// The policy's `sessions` (a process refused, EACCES) and the over-budget
// hold, as the monitor's hello-refused and over-budget events.
TEST_F(KmodAudit, SessionRefusedAndHoldNameTaskAndProcess) {
  contego_kmod_record refused = record(CONTEGO_KMOD_REC_SESSION_REFUSED);
  refused.task = 0;  // arm_init
  refused.pid = 412;
  refused.uid = 1000;
  refused.count = 1;
  contego_kmod_record hold = record(CONTEGO_KMOD_REC_HOLD);
  hold.task = 1;  // gripper
  hold.pid = 77;
  hold.uid = 990;
  hold.job = 5;
  hold.count = 3;
  hold.field_count = 1;
  hold.fields[0] = 4;
  for (const auto* r : {&refused, &hold}) ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  auto l = lines();
  ASSERT_EQ(l.size(), 2u);
  const std::string a = l[0]["detail"], b = l[1]["detail"];
  EXPECT_EQ(l[0]["kind"], "session-refused");
  EXPECT_NE(a.find("task 0 (" + names_.tasks[0] + "): pid 412 uid 1000 refused (EACCES)"),
            std::string::npos)
      << a;
  EXPECT_NE(a.find("already has 1 live session(s)"), std::string::npos) << a;
  EXPECT_EQ(l[1]["kind"], "over-budget");
  EXPECT_NE(b.find("task 1 (" + names_.tasks[1] + "): over its budget of 4 transfers per job"),
            std::string::npos)
      << b;
  EXPECT_NE(b.find("3 transfer(s) held"), std::string::npos) << b;
  EXPECT_NE(b.find("pid 77 uid 990"), std::string::npos) << b;
}

// Events carry the module's time too (its CLOCK_MONOTONIC when it took the
// record), not the time the reader writes them: a reader that was stopped
// for seconds writes the earlier instant.
TEST_F(KmodAudit, EventsCarryTheModulesTime) {
  timespec mono{}, wall{};
  clock_gettime(CLOCK_MONOTONIC, &mono);
  clock_gettime(CLOCK_REALTIME, &wall);
  const auto us = [](const timespec& t) {
    return static_cast<uint64_t>(t.tv_sec) * 1000000u + static_cast<uint64_t>(t.tv_nsec) / 1000u;
  };
  contego_kmod_record s = record(CONTEGO_KMOD_REC_SAFE_STATE);
  s.device = 0;
  s.why = CONTEGO_KMOD_SAFE_LOAD;
  s.time_us = us(mono) - 3000000;  // three seconds before the line is written
  contego_kmod_record refused = record(CONTEGO_KMOD_REC_SESSION_REFUSED);
  refused.task = 0;
  refused.time_us = us(mono) - 2000000;
  contego_kmod_record gap = record(CONTEGO_KMOD_REC_GAP);
  gap.count = 1;
  gap.time_us = us(mono) - 1000000;
  for (const auto* r : {&s, &refused, &gap}) ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  // The reader's own events (start, stop) keep the writer's time, no mono_us.
  ASSERT_TRUE(log_.event("stop", "reader"));
  auto l = lines();
  ASSERT_EQ(l.size(), 4u);
  const int64_t seconds_ago[] = {3, 2, 1};
  for (size_t i = 0; i < 3; ++i) {
    const contego_kmod_record* r = i == 0 ? &s : i == 1 ? &refused : &gap;
    ASSERT_TRUE(l[i].contains("mono_us")) << l[i].dump();
    EXPECT_EQ(l[i]["mono_us"].get<uint64_t>(), r->time_us) << l[i].dump();
    const int64_t t = l[i]["t_us"].get<int64_t>();
    const int64_t expected = static_cast<int64_t>(us(wall)) - seconds_ago[i] * 1000000;
    EXPECT_LT(std::llabs(t - expected), 500000) << l[i].dump();
  }
  EXPECT_FALSE(l[3].contains("mono_us"));
  EXPECT_GE(l[3]["t_us"].get<int64_t>(), static_cast<int64_t>(us(wall)));
  std::ifstream in(path_);
  const monitor::AuditCheck c = monitor::verify_audit(in);
  EXPECT_TRUE(c.ok) << c.error;
}

// A call refused because the module has no room for one more session
// (EAGAIN, max_sessions open; or no memory): the task, the process, how many
// are open and how many calls were so refused since the last record.
TEST_F(KmodAudit, SessionsFullNamesTaskProcessAndCount) {
  contego_kmod_record full = record(CONTEGO_KMOD_REC_SESSIONS_FULL);
  full.task = 1;  // gripper
  full.pid = 77;
  full.uid = 990;
  full.count = 3;
  full.field_count = 2;
  full.fields[0] = 1024;
  full.fields[1] = 1024;
  contego_kmod_record nomem = full;
  nomem.fields[0] = 12;
  nomem.count = 1;
  for (const auto* r : {&full, &nomem}) ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  auto l = lines();
  ASSERT_EQ(l.size(), 2u);
  const std::string a = l[0]["detail"], b = l[1]["detail"];
  EXPECT_EQ(l[0]["kind"], "session-refused");
  EXPECT_NE(a.find("task 1 (" + names_.tasks[1] + "): pid 77 uid 990 refused (EAGAIN)"),
            std::string::npos)
      << a;
  EXPECT_NE(a.find("1024 sessions open, its max_sessions"), std::string::npos) << a;
  EXPECT_NE(a.find("3 call(s) of the task so refused"), std::string::npos) << a;
  EXPECT_EQ(l[1]["kind"], "session-refused");
  EXPECT_NE(b.find("no memory for one more session (12 open, max_sessions 1024)"),
            std::string::npos)
      << b;
}

// A protected adapter removed and back (the module's bus notifier): one
// `adapter` line each, then the returned adapter's safe states name why.
TEST_F(KmodAudit, AdapterRemovedAndBackAreNamedWithTheirBus) {
  contego_kmod_record gone = record(CONTEGO_KMOD_REC_ADAPTER);
  gone.why = CONTEGO_KMOD_ADAPTER_REMOVED;
  gone.bus = 1;
  gone.count = 0;
  contego_kmod_record back = gone;
  back.why = CONTEGO_KMOD_ADAPTER_ADDED;
  contego_kmod_record safe = record(CONTEGO_KMOD_REC_SAFE_STATE);
  safe.device = 0;
  safe.why = CONTEGO_KMOD_SAFE_ADAPTER;
  for (const auto* r : {&gone, &back, &safe}) ASSERT_TRUE(write_kmod_record(log_, names_, *r));
  auto l = lines();
  ASSERT_EQ(l.size(), 3u);
  const std::string a = l[0]["detail"], b = l[1]["detail"], c = l[2]["detail"];
  EXPECT_EQ(l[0]["kind"], "adapter");
  EXPECT_NE(a.find("adapter i2c-0 (the policy's bus 1) removed"), std::string::npos) << a;
  EXPECT_EQ(l[1]["kind"], "adapter");
  EXPECT_NE(b.find("adapter i2c-0 (the policy's bus 1) back"), std::string::npos) << b;
  EXPECT_EQ(l[2]["kind"], "safe-state");
  EXPECT_NE(c.find("its adapter came back"), std::string::npos) << c;
}

// An operator's reset (`contego kmod reset`): a `reset` line as the
// monitor's, naming the device, who asked and whether it was latched.
TEST_F(KmodAudit, AResetNamesTheDeviceAndWhoAsked) {
  contego_kmod_record r = record(CONTEGO_KMOD_REC_RESET);
  r.device = 0;
  r.bus = 1;
  r.addr = 0x40;
  r.pid = 77;
  r.uid = 0;
  r.index = 1;
  contego_kmod_record again = r;
  again.index = 0;
  for (const auto* x : {&r, &again}) ASSERT_TRUE(write_kmod_record(log_, names_, *x));
  auto l = lines();
  ASSERT_EQ(l.size(), 2u);
  EXPECT_EQ(l[0]["kind"], "reset");
  EXPECT_EQ(l[0]["detail"],
            "contego.ko: device 0 (arm) at bus 1 0x40 reset by uid 0 (pid 77); it was latched");
  EXPECT_NE(std::string(l[1]["detail"]).find("it was not latched"), std::string::npos);
}

// The module's state as `kmod audit --metrics-file` writes it: contego_info,
// the counters, a latched device and a degraded load's gaps, every sample a
// family's HELP and TYPE name; a label with a quote escaped.
TEST(KmodMetrics, TheModulesStateInPrometheusFormat) {
  nlohmann::ordered_json j;
  j["loaded"] = true;
  j["image_sha256"] = std::string(64, 'a');
  j["devices"] = nlohmann::ordered_json::array();
  j["devices"].push_back(
      {{"name", "arm"}, {"latched", true}, {"undriven", false}, {"unread", false}});
  j["devices"].push_back(
      {{"name", "ta\"nk"}, {"latched", false}, {"undriven", false}, {"unread", true}});
  j["audit_reader"] = true;
  j["counters"] = {{"checks", 12}, {"refused", 3}, {"sessions", 2}};
  const std::string m = kmod_metrics_text(j);
  for (const char* line :
       {"contego_info{client=\"contego.ko\",image_sha256=\""
        "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\",loaded=\"1\"} 1\n",
        "contego_kmod_checks_total 12\n", "contego_kmod_refused_total 3\n",
        "contego_kmod_performed_total 0\n", "contego_kmod_sessions 2\n",
        "contego_kmod_audit_reader 1\n", "contego_device_latched{device=\"arm\"} 1\n",
        "contego_device_latched{device=\"ta\\\"nk\"} 0\n",
        "contego_device_unavailable{device=\"ta\\\"nk\",what=\"reading\"} 1\n"}) {
    EXPECT_NE(m.find(line), std::string::npos) << line << "\n" << m;
  }
  EXPECT_EQ(m.find("what=\"safe_state\""), std::string::npos) << m;
  std::istringstream in(m);
  std::set<std::string> typed;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# TYPE ", 0) == 0) typed.insert(line.substr(7, line.find(' ', 7) - 7));
    if (line.empty() || line[0] == '#') continue;
    EXPECT_TRUE(typed.count(line.substr(0, line.find_first_of("{ ")))) << line;
  }
  // No image read (a module that predates it): no device lines, no throw.
  nlohmann::ordered_json bare;
  bare["loaded"] = false;
  bare["counters"] = nlohmann::ordered_json::object();
  EXPECT_NE(kmod_metrics_text(bare).find("contego_kmod_checks_total 0"), std::string::npos);
}

// A call refused because a part of what its verdicts would send has no form
// on the adapter: an `inexpressible` line in the monitor's words (the same
// function words both from the planner's refusal).
TEST_F(KmodAudit, AnInexpressibleCallIsWordedAsTheMonitorWordsIt) {
  constexpr uint64_t kFuncs =
      bus::kI2cStubFuncs & ~bus::kFuncSmbusWriteByteData & ~bus::kFuncSmbusWriteI2cBlock;
  uint8_t pair[2] = {0x08, 0x64};
  const bus::Msg emit[1] = {{0x40, 0, 2, pair}};
  const bus::Plan monitor_plan = bus::plan_transfer(emit, kFuncs);
  ASSERT_EQ(monitor_plan.form, bus::Plan::Form::kRefused);
  contego_kmod_record r = record(CONTEGO_KMOD_REC_INEXPRESSIBLE);
  r.task = 1;
  r.pid = 77;
  r.uid = 990;
  r.bus = 1;
  r.addr = 0x40;
  r.reason = CONTEGO_I2C_NO_FORM;
  r.index = 1;
  r.fields[0] = 2 << 16;
  r.fields[2] = static_cast<int32_t>(kFuncs);
  r.fields[4] = 0 | 2 << 8 | CONTEGO_SMBUS_BYTE_DATA << 16 | CONTEGO_SMBUS_I2C_BLOCK_DATA << 24;
  r.field_count = 6;
  // A write and the read answering it, the read alone without a form.
  contego_kmod_record read = r;
  read.reason = CONTEGO_I2C_LONG_READ_ALONE;
  read.fields[0] = 2 << 16 | bus::kMsgRead;
  read.fields[4] = 0;
  ASSERT_TRUE(write_kmod_record(log_, names_, r));
  ASSERT_TRUE(write_kmod_record(log_, names_, read));
  auto l = lines();
  ASSERT_EQ(l.size(), 2u);
  const std::string a = l[0]["detail"], b = l[1]["detail"];
  EXPECT_EQ(l[0]["kind"], "inexpressible");
  EXPECT_NE(a.find("contego.ko: task 1 (" + names_.tasks[1] + "): bus 1: " + monitor_plan.reason +
                   "; the call refused (EOPNOTSUPP) before any part of it acted; pid 77 uid 990"),
            std::string::npos)
      << a;
  EXPECT_NE(a.find("write 2 at 0x40: the adapter has no plain I2C and no one of write byte data, "
                   "I2C block write (I2C_FUNCS 0x046f0000)"),
            std::string::npos)
      << a;
  EXPECT_EQ(l[1]["kind"], "inexpressible");
  EXPECT_NE(b.find("bus 1: read 2 at 0x40: a read of more than one byte needs a register byte"),
            std::string::npos)
      << b;
}

// The names follow the image in force: a policy-load record's CRC-32 picks
// the reader's policy with that image; an image of none of them leaves the
// records with numbers only.
// arm.policy's names (image CRC 0x1111) and another policy's (0x2222),
// whose tasks are pilot and observer and whose device 0 is `device`.
KmodNames two_policies(const monitor::NameTable& arm, const std::string& device) {
  monitor::NameTable other = arm;
  other.tasks = {"pilot", "observer"};
  if (!device.empty()) other.devices = {device};
  return KmodNames({{"arm.policy", 0x1111, arm}, {"other.policy", 0x2222, other}});
}

// A decision of task 1 on device 0's command 0.
contego_kmod_record task1_decision() {
  contego_kmod_record d = record(CONTEGO_KMOD_REC_DECISION);
  d.task = 1;
  d.device = 0;
  d.command = 0;
  return d;
}

TEST_F(KmodAudit, NamesFollowThePolicyLoadRecords) {
  KmodNames names = two_policies(names_, "");
  const contego_kmod_record d = task1_decision();
  auto write = [&](const contego_kmod_record& r) {
    const std::string note = names.follow(r);
    ASSERT_TRUE(write_kmod_record(log_, names.current(), r, note));
  };
  write(d);  // before any load record: the first policy's names
  contego_kmod_record ld = record(CONTEGO_KMOD_REC_LOAD);
  ld.field_count = 1;
  ld.fields[0] = 0x2222;
  write(ld);
  write(d);
  ld.fields[0] = 0x3333;
  write(ld);
  write(d);
  ld.fields[1] = 0x3333;  // in place (`contego kmod reload`): the image it replaced
  ld.field_count = 2;
  write(ld);
  auto l = lines();
  ASSERT_EQ(l.size(), 6u);
  EXPECT_NE(l[5]["detail"].get<std::string>().find(
                "in place (state carried over from image CRC-32 00003333, no safe state driven)"),
            std::string::npos)
      << l[5]["detail"];
  EXPECT_EQ(l[0]["task_name"], names_.tasks[1]);
  EXPECT_NE(l[1]["detail"].get<std::string>().find("00002222: other.policy"), std::string::npos)
      << l[1]["detail"];
  EXPECT_EQ(l[2]["task_name"], "observer");
  EXPECT_NE(l[3]["detail"].get<std::string>().find("none of the reader's --policy files"),
            std::string::npos)
      << l[3]["detail"];
  EXPECT_FALSE(l[4].contains("task_name")) << l[4];
  EXPECT_EQ(l[4]["task"], 1);
}

// A load withdrawn for a safe state not driven: its devices named by the
// withdrawn image, then the names of the image in force again (or none).
TEST_F(KmodAudit, AWithdrawnLoadNamesItsDevicesAndGivesTheNamesBack) {
  KmodNames names = two_policies(names_, "wheels");
  const contego_kmod_record d = task1_decision();
  auto write = [&](const contego_kmod_record& r) {
    const std::string note = names.follow(r);
    ASSERT_TRUE(write_kmod_record(log_, names.current(), r, note));
  };
  contego_kmod_record ld = record(CONTEGO_KMOD_REC_LOAD);
  ld.field_count = 1;
  ld.fields[0] = 0x2222;
  write(ld);
  contego_kmod_record refused = record(CONTEGO_KMOD_REC_LOAD_REFUSED);
  refused.reason = CONTEGO_KMOD_REFUSED_UNSAFE;
  refused.count = 644;
  refused.fields[0] = 0x1;
  refused.fields[2] = 0x1111;  // arm.policy's image stays in force
  refused.field_count = 3;
  write(refused);
  write(d);
  write(ld);
  refused.fields[0] = 0;
  refused.fields[1] = 0x1;  // a sensor not read
  refused.field_count = 2;  // nothing was in force before it
  write(refused);
  write(d);
  auto l = lines();
  ASSERT_EQ(l.size(), 6u);
  const std::string first = l[1]["detail"].get<std::string>();
  EXPECT_EQ(l[1]["kind"], "policy-load-refused");
  EXPECT_NE(first.find("the image of 644 bytes withdrawn after its load (a device absent, or "
                       "no form on its adapter): safe state of device(s) 0 (wheels) not driven; "
                       "the policy in force stays; image CRC-32 00001111: arm.policy, whose "
                       "names the records now carry again"),
            std::string::npos)
      << first;
  EXPECT_EQ(l[2]["task_name"], names_.tasks[1]);
  EXPECT_NE(l[4]["detail"].get<std::string>().find(
                "sensor(s) 0 (wheels) not read; no policy is in force"),
            std::string::npos)
      << l[4]["detail"];
  EXPECT_FALSE(l[5].contains("task_name")) << l[5];
}

}  // namespace
}  // namespace contego::cli
