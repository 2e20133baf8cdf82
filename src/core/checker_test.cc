// The check path on the rover image (frame device): transaction → device →
// command → class, access, latch, rate, invariants → verdict and audit.
#include <gtest/gtest.h>
#include <random>
#include <tuple>

#include "core/harness_fixture_test.h"
#include "core/test_fixtures.h"

namespace contego::core {
namespace {

using testing::emits;
using testing::Harness;
using testing::Prog;
namespace rover = testing::rover;
using Bytes = std::vector<uint8_t>;
using image::Named;

class RoverTest : public testing::HarnessTest {
 protected:
  void SetUp() override { load(rover::model()); }
  void sense(const int32_t (&raw)[5], uint64_t taken_at = 1000) {
    h.samples[rover::kLine].bytes = rover::sample(raw);
    h.samples[rover::kLine].taken_at_us = taken_at;
  }
  Verdict send(Bytes bytes, uint16_t task = rover::kFollower, uint64_t now = 1000,
               uint32_t job = 0) {
    return h.check(task, 0x08, std::move(bytes), now, job);
  }
  // Sends left() at 1, 2 and 3 ms under a latch of three: the first two are
  // invariant violations (failsafe) that do not latch the motor board yet, the
  // third latches it and drives its safe state, stop(). Returns the third verdict.
  Verdict three_violations_latch() {
    for (uint64_t t : {1000, 2000}) {
      const Verdict v = send({1, 97, 0, 0, 0}, rover::kFollower, t);
      EXPECT_EQ(v.decision, Decision::kFailsafe);
      EXPECT_EQ(v.reason, Reason::kInvariantViolated);
    }
    EXPECT_FALSE(h.checker->latched(rover::kGopigo));
    const Verdict third = send({1, 97, 0, 0, 0}, rover::kFollower, 3000);
    EXPECT_EQ(third.reason, Reason::kLatched);
    EXPECT_EQ(emits(third), (std::vector<Bytes>{{120, 0, 0, 0}}));  // safe state: stop
    EXPECT_TRUE(h.checker->latched(rover::kGopigo));
    return third;
  }
  // fwd() with the line centred and INV1 running `program`: its decision,
  // and in *executed the bytecode instructions the check ran.
  Decision forward_with_inv1(const Prog& program, uint64_t* executed) {
    image::ImageModel m = rover::model();
    m.invariants[rover::kInv1].record.code_first = testing::add_code(m, program);
    m.invariants[rover::kInv1].record.code_len = static_cast<uint16_t>(program.size());
    load(m);
    sense(rover::kCentre);
    const uint64_t before = h.checker->executed_instructions();
    const Decision d = send({1, 119, 0, 0, 0}).decision;
    *executed = h.checker->executed_instructions() - before;
    return d;
  }
  // The verdict on fwd() under `m`, the line sensor reading `line`.
  Verdict forward_under(const image::ImageModel& m, const int32_t (&line)[5]) {
    load(m);
    sense(line);
    return send({1, 119, 0, 0, 0});
  }
};

// `m` with INV1 running `program` instead of its own.
void replace_inv1_program(image::ImageModel& m, const Prog& program) {
  m.invariants[rover::kInv1].record.code_first = testing::add_code(m, program);
  m.invariants[rover::kInv1].record.code_len = static_cast<uint16_t>(program.size());
}

TEST(CheckerTest, NothingLoadedRejectsEverything) {
  Harness h;
  const Verdict v = h.check(0, 0x08, {120, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kNotLoaded);
  EXPECT_EQ(v.emit_count, 0);
  ASSERT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].command, kNone);
}

TEST_F(RoverTest, UnknownTaskIsRejected) {
  EXPECT_EQ(send({120, 0, 0, 0}, kNoTask).reason, Reason::kUnknownTask);
  EXPECT_EQ(send({120, 0, 0, 0}, 3).reason, Reason::kUnknownTask);
  EXPECT_EQ(send({120, 0, 0, 0}, 3).decision, Decision::kReject);
}

TEST_F(RoverTest, UnknownDeviceAddressOrBusIsRejected) {
  Verdict v = h.check(rover::kFollower, 0x09, {120, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kUnknownDevice);
  v = h.check(rover::kFollower, 0x08, {120, 0, 0, 0}, 1000, 0, TxKind::kWrite, /*bus=*/2);
  EXPECT_EQ(v.reason, Reason::kUnknownDevice);
}

TEST_F(RoverTest, OverlongWriteIsRejected) {
  const Verdict v = send(Bytes(kMaxWriteBytes + 1, 0));
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kTooLong);
}

TEST_F(RoverTest, ReadsNeedTheReadBit) {
  Verdict v = h.check(rover::kLogger, 0x06, {}, 1000, 0, TxKind::kRead);
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(v.reason, Reason::kReadAllowed);
  EXPECT_EQ(v.emit_count, 0);
  v = h.check(rover::kIntruder, 0x06, {}, 1000, 0, TxKind::kRead);
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kReadDenied);
  v = h.check(rover::kIntruder, 0x06, {}, 1000, 0, TxKind::kQuick);
  EXPECT_EQ(v.reason, Reason::kReadDenied);
  v = h.check(rover::kLogger, 0x08, {}, 1000, 0, TxKind::kQuick);  // gopigo: no read bit
  EXPECT_EQ(v.reason, Reason::kReadDenied);
}

TEST_F(RoverTest, QueryCommandNeedsReadAccessAndIsEmittedAsIs) {
  Verdict v = h.check(rover::kLogger, 0x06, {1, 3, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(v.reason, Reason::kReadAllowed);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 3, 0, 0, 0}}));
  v = h.check(rover::kIntruder, 0x06, {1, 3, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kReadDenied);
}

TEST_F(RoverTest, FramesAreAcceptedWithAndWithoutThePrefix) {
  sense(rover::kCentre);
  Verdict v = send({1, 119, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 119, 0, 0, 0}}));
  EXPECT_EQ(v.addr, 0x08);
  v = send({119, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{119, 0, 0, 0}}));
}

TEST_F(RoverTest, WrongFrameLengthsAreMalformed) {
  for (size_t len : {0u, 1u, 3u, 6u, 9u}) {
    const Verdict v = send(Bytes(len, 120));
    EXPECT_EQ(v.decision, Decision::kReject) << len;
    EXPECT_EQ(v.reason, Reason::kMalformed) << len;
    EXPECT_EQ(v.reply_errno, 22) << len;
  }
}

TEST_F(RoverTest, UnknownOpcodeIsRejected) {
  const Verdict v = send({1, 200, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kUnknownCommand);
}

TEST_F(RoverTest, ForbiddenCommandIsRejected) {
  const Verdict v = send({12, 7, 1, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kForbiddenCommand);
}

TEST_F(RoverTest, AccessIsDefaultDenyWithEperm) {
  const Verdict v = send({120, 0, 0, 0}, rover::kLogger);
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kAccessDenied);
  EXPECT_EQ(v.rule_kind, RuleKind::kAccess);
  EXPECT_EQ(v.reply_errno, 1);
  EXPECT_EQ(v.emit_count, 0);
}

TEST_F(RoverTest, CommandsOutsideEveryRuleAreAllowed) {
  // stop is in no invariant's mask and no rate limit: no sensor needed.
  const Verdict v = send({120, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kAllow);
  EXPECT_EQ(h.sample_reads, 0u);
}

TEST_F(RoverTest, RateLimitCountsPerJobNumber) {
  EXPECT_EQ(send({70, 150, 0, 0}, rover::kFollower, 1000, 7).decision, Decision::kAllow);
  EXPECT_EQ(send({71, 150, 0, 0}, rover::kFollower, 1001, 7).decision, Decision::kAllow);
  const Verdict third = send({70, 80, 0, 0}, rover::kFollower, 1002, 7);
  EXPECT_EQ(third.decision, Decision::kIgnore);
  EXPECT_EQ(third.reason, Reason::kRateExceeded);
  EXPECT_EQ(third.rule_kind, RuleKind::kRate);
  EXPECT_EQ(third.rule, 0);
  // Commands outside the rule's mask do not count and are not limited.
  EXPECT_EQ(send({120, 0, 0, 0}, rover::kFollower, 1003, 7).decision, Decision::kAllow);
  // The next job starts a new window even at the same time.
  EXPECT_EQ(send({70, 80, 0, 0}, rover::kFollower, 1003, 8).decision, Decision::kAllow);
}

TEST_F(RoverTest, RateLimitFallsBackToPeriodWindowsWithoutJobNumbers) {
  // follower period = 200 ms: [0, 200000) is one window.
  EXPECT_EQ(send({70, 1, 0, 0}, rover::kFollower, 10).decision, Decision::kAllow);
  EXPECT_EQ(send({70, 1, 0, 0}, rover::kFollower, 150000).decision, Decision::kAllow);
  EXPECT_EQ(send({70, 1, 0, 0}, rover::kFollower, 199999).decision, Decision::kIgnore);
  EXPECT_EQ(send({70, 1, 0, 0}, rover::kFollower, 200000).decision, Decision::kAllow);
}

TEST_F(RoverTest, RateLimitFailsafeUsesTheTemplateOnTheCheckedCommand) {
  image::ImageModel m = rover::model();
  m.rates[0].record.response = Response::kFailsafe;
  m.rates[0].record.template_id = rover::kTplSpeed80;
  load(m);
  send({70, 200, 0, 0}, rover::kFollower, 1, 1);
  send({70, 200, 0, 0}, rover::kFollower, 2, 1);
  const Verdict v = send({1, 71, 250, 0, 0}, rover::kFollower, 3, 1);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kRateExceeded);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 71, 80, 0, 0}}));  // prefix kept, speed forced
}

// Rule-based random test: the rate rule against a reference model of job
// windows (job numbers, or now / period when the job is 0).
TEST_F(RoverTest, RateLimitMatchesAReferenceModel) {
  std::mt19937 rng(2024);
  uint64_t now = 0;
  uint32_t job = 1;
  bool have_key = false;
  uint64_t key = 0;
  uint32_t count = 0;
  for (int i = 0; i < 5000; ++i) {
    now += rng() % 90000;
    const bool use_jobs = (i / 500) % 2 == 0;
    if (use_jobs && rng() % 4 == 0) ++job;
    const uint32_t tx_job = use_jobs ? job : 0;
    const uint64_t k = tx_job != 0 ? ((1ull << 63) | tx_job) : now / 200000;
    if (!have_key || k != key) {
      have_key = true;
      key = k;
      count = 0;
    }
    const auto pick = static_cast<uint32_t>(rng() % 3);
    const uint8_t opcode = pick == 0 ? 70 : pick == 1 ? 71 : 120;
    Decision expected = Decision::kAllow;
    if (opcode != 120) {
      ++count;
      if (count > 2) expected = Decision::kIgnore;
    }
    const Verdict v = send({opcode, 5, 0, 0}, rover::kFollower, now, tx_job);
    ASSERT_EQ(v.decision, expected) << "step " << i;
  }
}

TEST_F(RoverTest, InvariantPassesWhenTheExpectedCommandIsSent) {
  sense(rover::kLineLeft);
  EXPECT_EQ(send({1, 100, 0, 0, 0}).decision, Decision::kAllow);  // right
  sense(rover::kLineRight);
  EXPECT_EQ(send({1, 97, 0, 0, 0}).decision, Decision::kAllow);  // left
  sense(rover::kCentre);
  EXPECT_EQ(send({1, 119, 0, 0, 0}).decision, Decision::kAllow);  // fwd
}

TEST_F(RoverTest, InvariantFailWithTemplateSubstitutesKeepingThePrefix) {
  sense(rover::kLineLeft);  // pos < -2500: INV1 expects right()
  Verdict v = send({1, 119, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kInvariantViolated);
  EXPECT_EQ(v.rule_kind, RuleKind::kInvariant);
  EXPECT_EQ(v.rule, rover::kInv1);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 100, 0, 0, 0}}));
  v = send({119, 0, 0, 0});
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{100, 0, 0, 0}}));
}

TEST_F(RoverTest, InvariantFailSubstEmitsTheComputedCommand) {
  sense(rover::kCentre);  // INV3 expects fwd and substitutes it
  const Verdict v = send({1, 97, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.rule, rover::kInv3);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 119, 0, 0, 0}}));
}

TEST_F(RoverTest, InvariantFailWithRejectResponse) {
  image::ImageModel m = rover::model();
  m.invariants[rover::kInv1].record.response = Response::kReject;
  m.invariants[rover::kInv1].record.reply_errno = 121;
  const Verdict v = forward_under(m, rover::kLineLeft);
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reply_errno, 121);
  EXPECT_EQ(v.emit_count, 0);
}

TEST_F(RoverTest, InvariantFailsafeWithoutTemplateIgnores) {
  image::ImageModel m = rover::model();
  m.invariants[rover::kInv1].record.template_id = kNone;
  const Verdict v = forward_under(m, rover::kLineLeft);
  EXPECT_EQ(v.decision, Decision::kIgnore);
  EXPECT_EQ(v.reason, Reason::kInvariantViolated);
}

TEST_F(RoverTest, MissingSampleMakesSignalsUnavailableAndFailsClosed) {
  const Verdict v = send({1, 119, 0, 0, 0});   // no sample at all
  EXPECT_EQ(v.decision, Decision::kFailsafe);  // INV1 has a template: right()
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
  EXPECT_EQ(v.rule, rover::kInv1);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 100, 0, 0, 0}}));
}

TEST_F(RoverTest, StaleSampleIsUnavailable) {
  sense(rover::kCentre, /*taken_at=*/1000);
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 51000).decision, Decision::kAllow);
  const Verdict v = send({1, 119, 0, 0, 0}, rover::kFollower, 51001);  // 50001 us old
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
}

// The derived line position is kept across checks while the sample's bytes
// and freshness stay the same (docs/core.md, "Signals"): the second check runs
// only the invariants, not the five-term position program.
TEST_F(RoverTest, DerivedSignalIsKeptWhileTheSampleBytesAreUnchanged) {
  sense(rover::kCentre, 1000);
  uint64_t before = h.checker->executed_instructions();
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 1000).decision, Decision::kAllow);
  const uint64_t first = h.checker->executed_instructions() - before;
  sense(rover::kCentre, 1010);  // a new sample with the same bytes
  before = h.checker->executed_instructions();
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 1010).decision, Decision::kAllow);
  const uint64_t second = h.checker->executed_instructions() - before;
  EXPECT_LT(second, first);
  EXPECT_GT(second, 0u);  // the invariants still ran
}

TEST_F(RoverTest, KeptDerivedSignalIsRecomputedWhenTheSampleBytesChange) {
  sense(rover::kCentre, 1000);
  EXPECT_EQ(send({1, 119, 0, 0, 0}).decision, Decision::kAllow);
  // Same timestamp and length, other bytes: only comparing the bytes catches it.
  sense(rover::kLineLeft, 1000);
  Verdict v = send({1, 119, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.rule, rover::kInv1);
  sense(rover::kCentre, 1000);
  EXPECT_EQ(send({1, 119, 0, 0, 0}).decision, Decision::kAllow);
  h.samples[rover::kLine].bytes.clear();  // the host lost the sensor
  v = send({1, 119, 0, 0, 0});
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
}

TEST_F(RoverTest, KeptDerivedSignalBecomesUnavailableWhenTheSampleGoesStale) {
  sense(rover::kCentre, 1000);
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 1000).decision, Decision::kAllow);
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 51000).decision, Decision::kAllow);
  // Same bytes, but now 50001 us old: staleness is judged on every check.
  Verdict v = send({1, 119, 0, 0, 0}, rover::kFollower, 51001);
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
  v = send({1, 119, 0, 0, 0}, rover::kFollower, 60000);
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
  sense(rover::kCentre, 60000);  // a fresh sample with the same bytes again
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 60000).decision, Decision::kAllow);
}

TEST_F(RoverTest, OutOfRangeReadingIsUnavailable) {
  const int32_t junk[5] = {767, 815, 0xFFFF, 710, 700};  // bus returned 0xFF bytes
  sense(junk);
  EXPECT_EQ(send({1, 119, 0, 0, 0}).reason, Reason::kSignalUnavailable);
}

TEST_F(RoverTest, ExecutedInstructionsStayWithinTheWorstCase) {
  sense(rover::kCentre);
  const uint64_t before = h.checker->executed_instructions();
  send({1, 119, 0, 0, 0});  // every invariant passes: the longest path here
  const uint64_t used = h.checker->executed_instructions() - before;
  EXPECT_GT(used, 0u);
  EXPECT_LE(used, h.checker->worst_case_cost());
}

TEST_F(RoverTest, SensorIsSampledOncePerCheck) {
  sense(rover::kCentre);
  h.sample_reads = 0;
  send({1, 119, 0, 0, 0});  // three invariants, five raw signals, one derived
  EXPECT_EQ(h.sample_reads, 1u);
  send({1, 119, 0, 0, 0});
  EXPECT_EQ(h.sample_reads, 2u);  // memo is per check, not forever
}

// The loader fuses `PUSH c; <compare>; JZ` into one instruction (Fused).
// Here a jump also lands on the fused triple's compare, with two values on
// the stack: both ways in must decide as the image's own instructions, and
// executed_instructions() must count the image's instructions.
TEST_F(RoverTest, FusedComparesDecideAndCountAsTheInstructionsTheyReplace) {
  constexpr Op kCompares[] = {Op::kEq, Op::kNe, Op::kLt, Op::kLe, Op::kGt, Op::kGe};
  auto holds = [](Op op, int64_t a, int64_t b) {
    switch (op) {
      case Op::kEq:
        return a == b;
      case Op::kNe:
        return a != b;
      case Op::kLt:
        return a < b;
      case Op::kLe:
        return a <= b;
      case Op::kGt:
        return a > b;
      default:
        return a >= b;
    }
  };
  // INV1 alone decides (its template on FAIL); the others pass for fwd().
  auto run = [&](const Prog& p, uint64_t* executed) { return forward_with_inv1(p, executed); };
  // What the rest of the check executes after INV1 passes or fails (a
  // failing invariant ends the evaluation), plus INV1's one instruction.
  Prog pass;
  pass.op(Op::kPass);
  Prog fail;
  fail.op(Op::kFail);
  uint64_t after_pass = 0;
  uint64_t after_fail = 0;
  ASSERT_EQ(run(pass, &after_pass), Decision::kAllow);
  ASSERT_EQ(run(fail, &after_fail), Decision::kFailsafe);
  for (const Op op : kCompares) {
    for (const int32_t x : {-5, 0, 7}) {
      for (const int32_t y : {-5, 7}) {
        for (const int32_t c : {-5, 0, 7}) {
          for (const int32_t flag : {0, 1}) {
            SCOPED_TRACE(::testing::Message() << "op " << static_cast<int>(op) << " x " << x
                                              << " y " << y << " c " << c << " flag " << flag);
            Prog p;
            p.push(x).push(y).push(flag);
            const size_t to_compare = p.jump(Op::kJumpIfZero);  // flag 0: x <op> y
            p.op(Op::kDrop);
            p.push(c);  // flag 1: x <op> c (the fused triple starts here)
            p.land(to_compare).op(op);
            const size_t to_pass = p.jump(Op::kJumpIfZero);
            p.op(Op::kFail);
            p.land(to_pass).op(Op::kPass);
            const bool fails = flag != 0 ? holds(op, x, c) : holds(op, x, y);
            uint64_t executed = 0;
            EXPECT_EQ(run(p, &executed), fails ? Decision::kFailsafe : Decision::kAllow);
            // Through the fused triple: 9 instructions; jumping onto the compare: 7.
            EXPECT_EQ(executed - (fails ? after_fail : after_pass) + 1, flag != 0 ? 9u : 7u);
          }
        }
      }
    }
  }
}

// `SIGNAL s; PUSH c; <compare>; JZ` and `COMMAND; PUSH c; <compare>; JZ`
// are fused once more, the value included: the same decisions and counts as
// the four instructions. pos is 0 with the line centred, and fwd() is
// command 0, so one table serves both.
TEST_F(RoverTest, FusedSignalAndCommandComparesDecideAndCountAsTheInstructionsTheyReplace) {
  const Prog kValues[] = {Prog{}.signal(rover::kPos), Prog{}.op(Op::kCommand)};
  for (const Prog& value : kValues) {
    SCOPED_TRACE(::testing::Message() << "value op " << static_cast<int>(value.code()[0].op));
    // The same value read, dropped, then PASS or FAIL: what the rest costs.
    uint64_t after_pass = 0;
    uint64_t after_fail = 0;
    ASSERT_EQ(forward_with_inv1(Prog(value).op(Op::kDrop).op(Op::kPass), &after_pass),
              Decision::kAllow);
    ASSERT_EQ(forward_with_inv1(Prog(value).op(Op::kDrop).op(Op::kFail), &after_fail),
              Decision::kFailsafe);
    for (const auto& [op, c, holds] :
         {std::tuple{Op::kLt, 1, true}, std::tuple{Op::kGe, 0, true}, std::tuple{Op::kGt, 0, false},
          std::tuple{Op::kEq, 5, false}, std::tuple{Op::kNe, 5, true},
          std::tuple{Op::kLe, -1, false}}) {
      SCOPED_TRACE(::testing::Message() << "op " << static_cast<int>(op) << " c " << c);
      Prog p(value);
      p.push(c).op(op);
      const size_t to_fail = p.jump(Op::kJumpIfZero);
      p.op(Op::kPass);
      p.land(to_fail).op(Op::kFail);
      uint64_t executed = 0;
      EXPECT_EQ(forward_with_inv1(p, &executed), holds ? Decision::kAllow : Decision::kFailsafe);
      EXPECT_EQ(executed - (holds ? after_pass : after_fail), 5u - 3u);  // five against three
    }
  }
}

// A fused signal compare whose reading is missing ends the program as
// SIGNAL does: unavailable, fail closed.
TEST_F(RoverTest, FusedSignalCompareOfAMissingReadingIsUnavailable) {
  Prog p;
  p.signal(rover::kPos).push(0).op(Op::kGe);
  const size_t to_fail = p.jump(Op::kJumpIfZero);
  p.op(Op::kPass);
  p.land(to_fail).op(Op::kFail);
  image::ImageModel m = rover::model();
  replace_inv1_program(m, p);
  load(m);
  h.samples[rover::kLine].bytes.clear();  // no sample at all: pos is unavailable
  const Verdict v = send({1, 119, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.reason, Reason::kSignalUnavailable);
}

TEST_F(RoverTest, ProgramFaultFailsClosed) {
  image::ImageModel m = rover::model();
  Prog div0;
  div0.push(1).push(0).op(Op::kDiv).op(Op::kDrop).op(Op::kPass);
  replace_inv1_program(m, div0);
  m.invariants[rover::kInv1].record.template_id = kNone;
  const Verdict v = forward_under(m, rover::kCentre);
  EXPECT_EQ(v.decision, Decision::kIgnore);
  EXPECT_EQ(v.reason, Reason::kProgramFault);
}

TEST_F(RoverTest, OverflowFaultsTheProgram) {
  image::ImageModel m = rover::model();
  m.constants.push_back(INT64_MAX);
  Prog ovf;
  ovf.op(Op::kPushConst, 0).push(1).op(Op::kAdd).op(Op::kDrop).op(Op::kPass);
  replace_inv1_program(m, ovf);
  const Verdict v = forward_under(m, rover::kCentre);
  EXPECT_EQ(v.reason, Reason::kProgramFault);
  EXPECT_EQ(v.decision, Decision::kFailsafe);  // INV1's template
}

// An invariant on set_left_speed with a computed substitute: speed > 100 →
// the same command with speed 80.
image::ImageModel with_speed_cap(int32_t substitute) {
  image::ImageModel m = rover::model();
  Prog cap;
  cap.field(0).push(100).op(Op::kGt);
  const size_t ok = cap.jump(Op::kJumpIfZero);
  cap.op(Op::kSubstBegin, kNone).push(substitute).op(Op::kSubstField, 0).op(Op::kFailSubst);
  cap.land(ok).op(Op::kPass);
  testing::add_invariant(m, "speed_cap", rover::kGopigo, cap,
                         testing::mask_of({rover::kSetLeftSpeed}), Response::kIgnore, kNone);
  return m;
}

TEST_F(RoverTest, FailSubstEncodesComputedFieldValues) {
  load(with_speed_cap(80));
  Verdict v = send({1, 70, 200, 0, 0});
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{1, 70, 80, 0, 0}}));
  v = send({70, 90, 0, 0}, rover::kFollower, 1000, 99);
  EXPECT_EQ(v.decision, Decision::kAllow);
}

TEST_F(RoverTest, SubstituteThatDoesNotFitItsFieldFailsClosed) {
  load(with_speed_cap(300));  // speed is an 8-bit field
  const Verdict v = send({1, 70, 200, 0, 0});
  EXPECT_EQ(v.decision, Decision::kIgnore);
  EXPECT_EQ(v.reason, Reason::kEncodeFailed);
  EXPECT_EQ(v.emit_count, 0);
}

TEST_F(RoverTest, LastFieldAndSinceLastSeeWhatReachedTheBus) {
  // speed may change by at most 50 per command and not within 10 ms; with no
  // history yet the program faults and the template (speed 80) is written,
  // which then becomes the history.
  image::ImageModel m = rover::model();
  Prog slew;
  slew.field(0).op(Op::kLastField, 0).op(Op::kSub).op(Op::kAbs).push(50).op(Op::kGt);
  const size_t small = slew.jump(Op::kJumpIfZero);
  slew.op(Op::kFail);
  slew.land(small).op(Op::kSinceLast).push(10000).op(Op::kLt);
  const size_t late = slew.jump(Op::kJumpIfZero);
  slew.op(Op::kFail);
  slew.land(late).op(Op::kPass);
  testing::add_invariant(m, "slew", rover::kGopigo, slew, testing::mask_of({rover::kSetRightSpeed}),
                         Response::kIgnore, rover::kTplSpeed80);
  m.rates.clear();
  load(m);
  Verdict first = send({71, 200, 0, 0}, rover::kFollower, 1000);
  EXPECT_EQ(first.reason, Reason::kProgramFault);
  EXPECT_EQ(emits(first), (std::vector<Bytes>{{71, 80, 0, 0}}));
  EXPECT_EQ(send({71, 120, 0, 0}, rover::kFollower, 20000).decision, Decision::kAllow);
  EXPECT_EQ(send({71, 190, 0, 0}, rover::kFollower, 40000).decision, Decision::kIgnore);  // +70
  EXPECT_EQ(send({71, 150, 0, 0}, rover::kFollower, 25000).decision, Decision::kIgnore);  // 5 ms
  EXPECT_EQ(send({71, 150, 0, 0}, rover::kFollower, 60000).decision, Decision::kAllow);
}

TEST_F(RoverTest, HasLastGuardsTheHistoryBeforeTheFirstCommand) {
  // last(speed, 100): 100 until a command reached the bus; then at most +-50.
  image::ImageModel m = rover::model();
  Prog slew;
  slew.field(0).op(Op::kHasLast);
  const size_t none = slew.jump(Op::kJumpIfZero);
  slew.op(Op::kLastField, 0);
  const size_t done = slew.jump(Op::kJump);
  slew.land(none).push(100);
  slew.land(done).op(Op::kSub).op(Op::kAbs).push(50).op(Op::kGt);
  const size_t small = slew.jump(Op::kJumpIfZero);
  slew.op(Op::kFail);
  slew.land(small).op(Op::kPass);
  testing::add_invariant(m, "slew", rover::kGopigo, slew, testing::mask_of({rover::kSetRightSpeed}),
                         Response::kIgnore, kNone);
  m.rates.clear();
  load(m);
  EXPECT_EQ(send({71, 200, 0, 0}, rover::kFollower, 1000).decision, Decision::kIgnore);  // 100+100
  EXPECT_EQ(send({71, 140, 0, 0}, rover::kFollower, 2000).decision, Decision::kAllow);   // no fault
  EXPECT_EQ(send({71, 200, 0, 0}, rover::kFollower, 3000).decision, Decision::kIgnore);  // 140+60
  EXPECT_EQ(send({71, 190, 0, 0}, rover::kFollower, 4000).decision, Decision::kAllow);
}

// The rover model with a latch on the motor board: `count` violations within
// `window_us` latch it in `mode`.
image::ImageModel with_latch(LatchMode mode, uint8_t count, uint32_t window_us) {
  image::ImageModel m = rover::model();
  m.devices[rover::kGopigo].record.latch_mode = mode;
  m.devices[rover::kGopigo].record.latch_count = count;
  m.devices[rover::kGopigo].record.latch_window_us = window_us;
  return m;
}

TEST_F(RoverTest, LatchAfterKViolationsDrivesSafeStateThenIgnores) {
  load(with_latch(LatchMode::kHoldSafe, 3, 1000000));
  sense(rover::kCentre, 0);
  const Verdict third = three_violations_latch();
  EXPECT_EQ(third.decision, Decision::kFailsafe);
  EXPECT_EQ(third.rule_kind, RuleKind::kLatch);
  // Even a valid command is now ignored.
  const Verdict held = send({1, 119, 0, 0, 0}, rover::kFollower, 4000);
  EXPECT_EQ(held.decision, Decision::kIgnore);
  EXPECT_EQ(held.reason, Reason::kLatched);
  h.checker->reset_latch(rover::kGopigo);
  EXPECT_FALSE(h.checker->latched(rover::kGopigo));
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 5000).decision, Decision::kAllow);
}

TEST_F(RoverTest, ViolationsSpreadBeyondTheWindowDoNotLatch) {
  load(with_latch(LatchMode::kHoldSafe, 2, 10000));
  h.samples[rover::kLine].bytes = rover::sample(rover::kCentre);
  for (uint64_t t = 0; t < 10; ++t) {
    h.samples[rover::kLine].taken_at_us = t * 20000;
    EXPECT_EQ(send({1, 97, 0, 0, 0}, rover::kFollower, t * 20000).reason,
              Reason::kInvariantViolated);
  }
  EXPECT_FALSE(h.checker->latched(rover::kGopigo));
}

TEST_F(RoverTest, AnUnrepairedLatchIgnoresExpectedSubstitutesAndForbiddenCommands) {
  load(with_latch(LatchMode::kHoldSafeUnrepaired, 3, 1000000));
  sense(rover::kCentre, 0);
  // left() on the line: INV3 substitutes the expected fwd(), five times.
  for (uint64_t t = 1; t <= 5; ++t) {
    const Verdict v = send({1, 97, 0, 0, 0}, rover::kFollower, t * 1000);
    EXPECT_EQ(v.decision, Decision::kFailsafe);
    EXPECT_EQ(v.reason, Reason::kInvariantViolated);
  }
  // A forbidden command is refused and does not count either.
  for (uint64_t t = 6; t <= 9; ++t) {
    EXPECT_EQ(send({1, 12, 1, 1, 0}, rover::kFollower, t * 1000).reason, Reason::kForbiddenCommand);
  }
  // Nor does a task without access to the device.
  for (uint64_t t = 10; t <= 13; ++t) {
    EXPECT_EQ(send({1, 120, 0, 0, 0}, rover::kIntruder, t * 1000).reason, Reason::kAccessDenied);
  }
  EXPECT_FALSE(h.checker->latched(rover::kGopigo));
  EXPECT_EQ(send({1, 119, 0, 0, 0}, rover::kFollower, 14000).decision, Decision::kAllow);
}

TEST_F(RoverTest, AnUnrepairedLatchCountsTemplateResponsesAndFaults) {
  load(with_latch(LatchMode::kHoldSafeUnrepaired, 3, 1000000));
  sense(rover::kLineLeft, 0);
  // left() with the line on the left: INV1 answers with its template right().
  three_violations_latch();
}

TEST_F(RoverTest, SafeStateIsTheEncodedTemplates) {
  Verdict v{};
  ASSERT_TRUE(h.checker->safe_state(rover::kGopigo, &v));
  EXPECT_EQ(v.decision, Decision::kFailsafe);
  EXPECT_EQ(v.addr, 0x08);
  EXPECT_EQ(emits(v), (std::vector<Bytes>{{120, 0, 0, 0}}));
  EXPECT_FALSE(h.checker->safe_state(rover::kLine, &v));  // none declared
  EXPECT_FALSE(h.checker->safe_state(17, &v));
}

TEST_F(RoverTest, AuditRecordCarriesRuleFieldsAndBothByteStrings) {
  load(with_speed_cap(80));
  const Verdict v = send({1, 70, 200, 0, 0}, rover::kFollower, 4242, 9);
  ASSERT_EQ(v.decision, Decision::kFailsafe);
  ASSERT_EQ(h.audits.size(), 1u);
  const AuditRecord& a = h.audits[0];
  EXPECT_EQ(a.time_us, 4242u);
  EXPECT_EQ(a.job, 9u);
  EXPECT_EQ(a.task, rover::kFollower);
  EXPECT_EQ(a.device, rover::kGopigo);
  EXPECT_EQ(a.command, rover::kSetLeftSpeed);
  EXPECT_EQ(a.rule_kind, RuleKind::kInvariant);
  EXPECT_EQ(a.rule, 3);
  EXPECT_EQ(a.decision, Decision::kFailsafe);
  EXPECT_EQ(a.reason, Reason::kInvariantViolated);
  EXPECT_EQ(a.field_count, 1);
  EXPECT_EQ(a.fields[0], 200);
  EXPECT_EQ(a.original_len, 5);
  EXPECT_EQ(h.audit_substitutes[0], (Bytes{1, 70, 80, 0, 0}));
}

TEST_F(RoverTest, UndecodedTransactionGetsOneAuditRecord) {
  send({1, 200, 0, 0, 0});
  ASSERT_EQ(h.audits.size(), 1u);
  EXPECT_EQ(h.audits[0].command, kNone);
  EXPECT_EQ(h.audits[0].reason, Reason::kUnknownCommand);
  EXPECT_EQ(h.audits[0].device, rover::kGopigo);
}

}  // namespace
}  // namespace contego::core
