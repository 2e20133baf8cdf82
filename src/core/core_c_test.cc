// The C facade: storage provided by the caller, C host callbacks, verdicts.
#include "contego/core_c.h"

#include <cstring>
#include <gtest/gtest.h>
#include <vector>

#include "core/test_fixtures.h"

namespace contego::core {
namespace {

namespace rover = testing::rover;

// The limits core_c.h exports to C hosts (contego.ko sizes its tables by them).
static_assert(CONTEGO_MAX_TASKS == kMaxTasks && CONTEGO_MAX_DEVICES == kMaxDevices &&
              CONTEGO_MAX_SAMPLE_BYTES == kMaxSampleBytes);

struct CHost {
  std::vector<uint8_t> sample;
  int audits = 0;
  uint8_t last_reason = 0xFF;
};

uint32_t c_read_sample(void* ctx, uint16_t, uint8_t* buf, uint32_t capacity, uint64_t* taken) {
  auto* h = static_cast<CHost*>(ctx);
  if (h->sample.size() > capacity) return 0;
  std::copy(h->sample.begin(), h->sample.end(), buf);
  *taken = 0;
  return static_cast<uint32_t>(h->sample.size());
}

void c_audit(void* ctx, const contego_audit_record* r) {
  auto* h = static_cast<CHost*>(ctx);
  ++h->audits;
  h->last_reason = r->reason;
}

TEST(CoreCTest, InitRefusesSmallOrMisalignedStorage) {
  std::vector<uint8_t> small(16);
  EXPECT_EQ(contego_checker_init(small.data(), small.size()), nullptr);
  EXPECT_EQ(contego_checker_init(nullptr, contego_checker_size()), nullptr);
  EXPECT_GE(contego_checker_align(), 8u);
}

TEST(CoreCTest, LoadCheckSafeStateAndLatchThroughTheCApi) {
  std::vector<uint64_t> storage(contego_checker_size() / 8 + 1);
  contego_checker* c = contego_checker_init(storage.data(), storage.size() * 8);
  ASSERT_NE(c, nullptr);

  std::vector<uint8_t> img = image::serialize(rover::model());
  img[img.size() - 1] ^= 1;
  contego_load_result bad = contego_load(c, img.data(), static_cast<uint32_t>(img.size()));
  EXPECT_EQ(bad.status, static_cast<uint8_t>(LoadStatus::kBadChecksum));
  EXPECT_STREQ(contego_load_status_name(bad.status), "bad-checksum");
  img[img.size() - 1] ^= 1;
  ASSERT_EQ(contego_load(c, img.data(), static_cast<uint32_t>(img.size())).status, 0);
  EXPECT_GT(contego_worst_case_cost(c), 0u);
  EXPECT_EQ(contego_task_period_us(c, 0), 200000u);  // follower
  EXPECT_EQ(contego_task_period_us(c, 1), 100000u);  // logger
  EXPECT_EQ(contego_task_period_us(c, CONTEGO_NONE), 0u);
  // What a host needs to sample the sensors and drive a task's actuators.
  EXPECT_EQ(contego_device_count(c), 2u);
  EXPECT_EQ(contego_task_actuates(c, 0), 1u << rover::kGopigo);  // follower
  EXPECT_EQ(contego_task_actuates(c, 1), 0u);                    // logger reads only
  // The rover's devices are frames: no register map to read back or seed.
  uint8_t regs[256];
  EXPECT_EQ(contego_command_registers(c, rover::kGopigo, regs), 0u);
  EXPECT_EQ(contego_command_registers(c, rover::kGopigo, nullptr), 0u);
  EXPECT_EQ(contego_seed_register(c, rover::kGopigo, 0, 0), 0);
  EXPECT_EQ(contego_task_actuates(c, CONTEGO_NONE), 0u);
  contego_device_info info{};
  ASSERT_EQ(contego_device_info_of(c, rover::kLine, &info), 1);
  EXPECT_EQ(info.role, CONTEGO_ROLE_SENSOR);
  EXPECT_EQ(info.bus, 1);
  EXPECT_EQ(info.addr, 0x06);
  EXPECT_EQ(info.sample_request_len, 5);
  EXPECT_EQ(info.sample_request[0], 1);
  EXPECT_EQ(info.sample_request[1], 3);
  EXPECT_EQ(info.sample_len, 10);
  EXPECT_EQ(info.sample_period_us, 10000u);
  EXPECT_EQ(info.max_sample_age_us, 50000u);
  ASSERT_EQ(contego_device_info_of(c, rover::kGopigo, &info), 1);
  EXPECT_EQ(info.role, CONTEGO_ROLE_ACTUATOR);
  EXPECT_EQ(info.sample_len, 0);
  EXPECT_EQ(contego_device_info_of(c, 2, &info), 0);
  EXPECT_EQ(contego_device_info_of(c, 0, nullptr), 0);

  CHost host;
  host.sample = rover::sample(rover::kLineLeft);
  contego_host h{&host, c_read_sample, c_audit};
  contego_set_host(c, &h);

  const uint8_t fwd[] = {1, 119, 0, 0, 0};
  contego_transaction tx{};
  tx.task = rover::kFollower;
  tx.bus = 1;
  tx.kind = CONTEGO_TX_WRITE;
  tx.addr = 0x08;
  tx.len = sizeof(fwd);
  tx.bytes = fwd;
  tx.now_us = 10;
  contego_verdict v{};
  contego_check(c, &tx, &v);
  EXPECT_EQ(v.decision, CONTEGO_FAILSAFE);  // line far left: right() instead
  EXPECT_STREQ(contego_decision_name(v.decision), "failsafe");
  EXPECT_STREQ(contego_reason_name(v.reason), "invariant-violated");
  ASSERT_EQ(v.emit_count, 1);
  EXPECT_EQ(v.emit_bytes[1], 100);
  EXPECT_EQ(host.audits, 1);
  EXPECT_EQ(host.last_reason, static_cast<uint8_t>(Reason::kInvariantViolated));

  // A transfer through the C API: the check acted (fail-safe), the abort
  // audits that it did not.
  contego_begin_transfer(c);
  contego_check(c, &tx, &v);
  EXPECT_EQ(host.audits, 2);
  contego_abort_transfer(c, CONTEGO_REJECT);
  EXPECT_EQ(host.audits, 3);
  EXPECT_STREQ(contego_reason_name(host.last_reason), "transfer-dropped");
  contego_begin_transfer(c);
  contego_check(c, &tx, &v);
  contego_commit_transfer(c);
  EXPECT_EQ(host.audits, 4);

  contego_verdict preview{};
  EXPECT_EQ(contego_preview_safe_state(c, rover::kGopigo, &preview), 1);
  EXPECT_EQ(contego_safe_state(c, rover::kGopigo, &v), 1);
  EXPECT_EQ(v.emit_bytes[0], 120);
  EXPECT_EQ(std::memcmp(preview.emit_bytes, v.emit_bytes, v.emit_bytes_used), 0);
  EXPECT_EQ(contego_latched(c, rover::kGopigo), 0);
  contego_reset_latch(c, rover::kGopigo);
}

// Reload in place through the C API (what contego.ko does): the job's rate
// count goes on in the new checker; a map with an id the old image does not
// have is refused and nothing is taken.
TEST(CoreCTest, CarryFromTakesTheOldCheckersStateForPairedRecords) {
  std::vector<uint8_t> img = image::serialize(rover::model());
  auto make = [&](std::vector<uint64_t>& storage) {
    storage.resize(contego_checker_size() / 8 + 1);
    contego_checker* c = contego_checker_init(storage.data(), storage.size() * 8);
    EXPECT_EQ(contego_load(c, img.data(), static_cast<uint32_t>(img.size())).status, 0);
    return c;
  };
  std::vector<uint64_t> a, b, d;
  contego_checker* old = make(a);
  const uint8_t speed[] = {70, 90, 0, 0};
  contego_transaction tx{};
  tx.task = rover::kFollower;
  tx.bus = 1;
  tx.kind = CONTEGO_TX_WRITE;
  tx.addr = 0x08;
  tx.len = sizeof(speed);
  tx.bytes = speed;
  tx.job = 5;
  tx.now_us = 1005;
  contego_verdict v{};
  for (int i = 0; i < 2; ++i) {  // the rate limit's two per job
    contego_check(old, &tx, &v);
    ASSERT_EQ(v.decision, CONTEGO_ALLOW);
  }
  contego_record_counts n{};
  contego_record_counts_of(old, &n);
  EXPECT_EQ(n.tasks, rover::model().tasks.size());
  EXPECT_EQ(n.devices, 2u);
  EXPECT_EQ(n.commands, rover::model().commands.size());
  EXPECT_EQ(n.rates, 1u);
  EXPECT_EQ(n.invariants, rover::model().invariants.size());
  std::vector<uint16_t> tasks(n.tasks), devices(n.devices), commands(n.commands), rates(n.rates),
      invariants(n.invariants);
  for (auto* v16 : {&tasks, &devices, &commands, &rates, &invariants}) {
    for (size_t i = 0; i < v16->size(); ++i) (*v16)[i] = static_cast<uint16_t>(i);
  }
  const contego_carry_map map{tasks.data(), devices.data(), commands.data(), rates.data(),
                              invariants.data()};
  contego_checker* carried = make(b);
  uint32_t dropped = 99;
  ASSERT_EQ(contego_carry_from(carried, old, &map, &dropped), 1);
  EXPECT_EQ(dropped, 0u);
  contego_check(carried, &tx, &v);
  EXPECT_EQ(v.decision, CONTEGO_IGNORE);  // the third of the job: over the rate
  contego_checker* fresh = make(d);
  contego_check(fresh, &tx, &v);
  EXPECT_EQ(v.decision, CONTEGO_ALLOW);  // without the carry it starts afresh

  devices[0] = 7;  // the old image has two devices
  std::vector<uint64_t> e;
  contego_checker* refused = make(e);
  EXPECT_EQ(contego_carry_from(refused, old, &map, &dropped), 0);
  contego_check(refused, &tx, &v);
  EXPECT_EQ(v.decision, CONTEGO_ALLOW);  // nothing was taken
  EXPECT_EQ(contego_carry_from(nullptr, old, &map, &dropped), 0);
  EXPECT_EQ(contego_carry_from(refused, old, nullptr, &dropped), 0);
  contego_record_counts_of(nullptr, &n);
  EXPECT_EQ(n.tasks, 0u);
}

TEST(CoreCTest, NullArgumentsFailClosedOrAreIgnored) {
  contego_load_result r = contego_load(nullptr, nullptr, 0);
  EXPECT_EQ(r.status, static_cast<uint8_t>(LoadStatus::kTooSmall));
  contego_set_host(nullptr, nullptr);
  contego_verdict v{};
  v.decision = CONTEGO_ALLOW;
  contego_check(nullptr, nullptr, &v);
  EXPECT_EQ(v.decision, CONTEGO_REJECT);
  EXPECT_STREQ(contego_reason_name(v.reason), "not-loaded");
  contego_check(nullptr, nullptr, nullptr);  // nowhere to answer: nothing happens
  EXPECT_EQ(contego_safe_state(nullptr, 0, &v), 0);
  EXPECT_EQ(contego_preview_safe_state(nullptr, 0, &v), 0);
  contego_begin_transfer(nullptr);
  contego_commit_transfer(nullptr);
  contego_abort_transfer(nullptr, CONTEGO_REJECT);
  contego_reset_latch(nullptr, 0);
  EXPECT_EQ(contego_latched(nullptr, 0), 0);
  uint8_t regs[256];
  EXPECT_EQ(contego_command_registers(nullptr, 0, regs), 0u);
  EXPECT_EQ(contego_seed_register(nullptr, 0, 0, 0), 0);
  contego_device_info info{};
  EXPECT_EQ(contego_device_info_of(nullptr, 0, &info), 0);
  EXPECT_EQ(contego_device_count(nullptr), 0u);
  EXPECT_EQ(contego_task_actuates(nullptr, 0), 0u);
  EXPECT_EQ(contego_worst_case_cost(nullptr), 0u);
  uint32_t decider = 7;
  EXPECT_EQ(contego_combine_transfer(nullptr, 2, &decider), 1);  // refuse
  EXPECT_EQ(decider, 0u);
  EXPECT_STREQ(contego_decision_name(200), "unknown");

  std::vector<uint64_t> storage(contego_checker_size() / 8 + 1);
  contego_checker* c = contego_checker_init(storage.data(), storage.size() * 8);
  ASSERT_NE(c, nullptr);
  v.decision = CONTEGO_ALLOW;
  contego_check(c, nullptr, &v);  // no transaction: malformed
  EXPECT_EQ(v.decision, CONTEGO_REJECT);
  EXPECT_EQ(v.reply_errno, 22);
  EXPECT_EQ(contego_safe_state(c, 0, nullptr), 0);
  EXPECT_EQ(contego_preview_safe_state(c, 0, &v), 0);  // nothing loaded
}

}  // namespace
}  // namespace contego::core
