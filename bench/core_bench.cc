// ns per check, checks per second and bytecode instructions per check of the
// trusted core, for a rover-like policy (frame device, INV1-INV3 over a
// line position derived from five raw readings, a rate limit) and an arm-like
// policy (PCA9685 register map, staged byte writes, a range and a sequence
// invariant). Images are built by hand with image::ImageModel (the fixtures of
// the core's tests).
// TODO(policy): build from policies/*.policy with the compiler instead.
#include <array>
#include <benchmark/benchmark.h>

#include "core/test_fixtures.h"

namespace contego::core {
namespace {

namespace rover = testing::rover;
namespace arm = testing::arm;

struct Bench {
  testing::Harness h;
  explicit Bench(const image::ImageModel& m) {
    if (h.load(m).status != LoadStatus::kOk) std::abort();
    // No audit sink: a real host's sink cost is the host's, not the core's.
    Host host{};
    host.context = &h;
    host.read_sample = [](void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                          uint64_t* taken) -> uint32_t {
      const auto& s = static_cast<testing::Harness*>(ctx)->samples[device];
      if (s.bytes.size() > capacity) return 0;
      std::memcpy(buf, s.bytes.data(), s.bytes.size());
      *taken = s.taken_at_us;
      return static_cast<uint32_t>(s.bytes.size());
    };
    h.checker->set_host(host);
  }
};

void report(benchmark::State& state, const Checker& c, uint64_t insns_before, uint64_t checks) {
  state.counters["checks/s"] =
      benchmark::Counter(static_cast<double>(checks), benchmark::Counter::kIsRate);
  state.counters["insns/check"] =
      static_cast<double>(c.executed_instructions() - insns_before) / static_cast<double>(checks);
  state.counters["worst_case_insns"] = c.worst_case_cost();
}

// Checks `tx` once per benchmark iteration, `prepare(tx, n)` first (n: the
// checks so far), reports the counters and returns the last verdict.
template <typename Prepare>
Verdict check_repeatedly(benchmark::State& state, Bench& b, Transaction& tx, Prepare prepare) {
  Verdict v{};
  const uint64_t before = b.h.checker->executed_instructions();
  uint64_t checks = 0;
  for (auto _ : state) {
    prepare(tx, checks);
    b.h.checker->check(tx, &v);
    benchmark::DoNotOptimize(v.decision);
    ++checks;
  }
  report(state, *b.h.checker, before, checks);
  return v;
}

// Checks one follower frame over and over with the line centred (fresh
// samples each time); the decision must be `expect`.
void check_centred(benchmark::State& state, std::array<uint8_t, 5> frame, Decision expect,
                   const char* otherwise) {
  Bench b(rover::model());
  b.h.samples[rover::kLine].bytes = rover::sample(rover::kCentre);
  Transaction tx{
      rover::kFollower, 1, TxKind::kWrite, 0x08, 0, 0, 0, static_cast<uint32_t>(frame.size()),
      frame.data(),     0};
  const Verdict v = check_repeatedly(state, b, tx, [&](Transaction& t, uint64_t) {
    t.now_us += 10;
    b.h.samples[rover::kLine].taken_at_us = t.now_us;
  });
  if (v.decision != expect) state.SkipWithError(otherwise);
}

// One allowed fwd() frame (prefixed, as the C library sends it) with the line
// centred: all three invariants run, the derived position is computed once.
void BM_RoverAllowedFwd(benchmark::State& state) {
  check_centred(state, {1, 119, 0, 0, 0}, Decision::kAllow, "expected allow");
}
BENCHMARK(BM_RoverAllowedFwd);

// The spoofing attack of the paper: left() while the line is centred; INV3
// substitutes fwd() (FAIL_SUBST), so the check also encodes a substitute.
void BM_RoverSpoofedLeftSubstituted(benchmark::State& state) {
  check_centred(state, {1, 97, 0, 0, 0}, Decision::kFailsafe, "expected failsafe");
}
BENCHMARK(BM_RoverSpoofedLeftSubstituted);

// Rate-limited speed frames: one job per pair, the third in a job is ignored.
void BM_RoverRateLimitedSpeed(benchmark::State& state) {
  Bench b(rover::model());
  const uint8_t frame[] = {1, 70, 80, 0, 0};
  Transaction tx{rover::kFollower, 1, TxKind::kWrite, 0x08, 0, 0, 1, sizeof(frame), frame, 0};
  check_repeatedly(state, b, tx, [](Transaction& t, uint64_t checks) {
    t.now_us += 10;
    t.job = static_cast<uint32_t>(1 + checks / 3);
  });
}
BENCHMARK(BM_RoverRateLimitedSpeed);

// set_pwm(ch, 0, off) as four single-byte writes (Adafruit PureIO): three are
// staged, the fourth commits the channel and runs the range invariant. One
// benchmark iteration = one transaction.
void BM_ArmByteWiseWrites(benchmark::State& state) {
  Bench b(arm::model());
  uint8_t w[2] = {0, 0};
  Transaction tx{arm::kController, 1, TxKind::kWrite, 0x40, 0, 0, 0, 2, w, 0};
  check_repeatedly(state, b, tx, [&w](Transaction& t, uint64_t checks) {
    const uint32_t step = static_cast<uint32_t>(checks % 4);
    const uint8_t ch = 3;
    w[0] = static_cast<uint8_t>(0x06 + 4 * ch + step);
    w[1] = step == 2 ? 0x77 : step == 3 ? 0x01 : 0x00;  // off = 375
    t.now_us += 10;
  });
}
BENCHMARK(BM_ArmByteWiseWrites);

// The gripper (channel 5) as one auto-increment block write, alternating
// 420 / 577 so the sequence invariant passes and advances its state word.
void BM_ArmGripperSequenceBlock(benchmark::State& state) {
  Bench b(arm::model());
  b.h.checker->seed_register(arm::kArm, 0x00, 0x21);  // MODE1.AI
  uint8_t w[5] = {0x06 + 4 * 5, 0, 0, 0, 0};
  Transaction tx{arm::kController, 1, TxKind::kWrite, 0x40, 0, 0, 0, 5, w, 0};
  const Verdict v = check_repeatedly(state, b, tx, [&w](Transaction& t, uint64_t checks) {
    const bool open = checks % 2 == 0;
    w[3] = open ? 0xA4 : 0x41;
    w[4] = open ? 0x01 : 0x02;
    t.now_us += 10;
  });
  if (v.decision != Decision::kAllow) state.SkipWithError("expected allow");
}
BENCHMARK(BM_ArmGripperSequenceBlock);

}  // namespace
}  // namespace contego::core

BENCHMARK_MAIN();
