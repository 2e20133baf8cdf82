// Test-only image builders for the core's tests and benchmarks: a GoPiGo-like
// rover (frame device + line-follower sensor, derived line position, INV1-INV3,
// a rate limit) and a PCA9685-like arm (register map with auto-increment bit,
// staged byte writes, a range invariant and a sequence invariant). Built with
// image::ImageModel and image::serialize (serialize.cc needs only the standard
// library, so core-only cross builds compile it straight into the tests).
//
// TODO(policy): once the policy compiler lands, build these from
// policies/*.policy instead of by hand.
#ifndef CONTEGO_CORE_TEST_FIXTURES_H_
#define CONTEGO_CORE_TEST_FIXTURES_H_

#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "contego/core/checker.h"

#include "image/image_model.h"

namespace contego::core::testing {

using image::ImageModel;
using image::Named;

// A tiny assembler: ops, pushes and forward jumps patched by label.
class Prog {
 public:
  Prog& op(Op o, uint16_t b = 0, int32_t imm = 0) {
    code_.push_back(Insn{o, 0, b, imm});
    return *this;
  }
  Prog& push(int32_t v) { return op(Op::kPush, 0, v); }
  Prog& signal(uint16_t s) { return op(Op::kSignal, s); }
  Prog& field(uint16_t f) { return op(Op::kField, f); }
  // Emits a jump (kJumpIfZero or kJump) to be patched by land(); returns its position.
  size_t jump(Op o) {
    code_.push_back(Insn{o, 0, 0, 0});
    return code_.size() - 1;
  }
  // Points the jump at `at` to the next instruction emitted.
  Prog& land(size_t at) {
    code_[at].imm = static_cast<int32_t>(code_.size() - at);
    return *this;
  }
  const std::vector<Insn>& code() const { return code_; }
  size_t size() const { return code_.size(); }

 private:
  std::vector<Insn> code_;
};

inline uint16_t add_code(ImageModel& m, const Prog& p) {
  const auto first = static_cast<uint16_t>(m.code.size());
  m.code.insert(m.code.end(), p.code().begin(), p.code().end());
  return first;
}

inline CommandMask mask_of(std::initializer_list<uint32_t> commands) {
  CommandMask m{};
  for (uint32_t c : commands) m.bits[c / 32] |= 1u << (c % 32);
  return m;
}

using FieldList = std::vector<std::pair<const char*, FieldRecord>>;

// Appends command `c` and its fields (after the fields already there).
inline void add_command(ImageModel& m, Named<CommandRecord> c, const FieldList& fields) {
  c.record.field_first = static_cast<uint16_t>(m.fields.size());
  c.record.field_count = static_cast<uint8_t>(fields.size());
  for (const auto& [name, f] : fields) m.fields.push_back(Named<FieldRecord>{f, name});
  m.commands.push_back(c);
}

// Appends invariant `name` of `device`: program `p` over `commands`.
inline void add_invariant(ImageModel& m, const char* name, uint16_t device, const Prog& p,
                          CommandMask commands, Response response, uint16_t tpl, uint8_t err = 0) {
  Named<InvariantRecord> v;
  v.name = name;
  v.record.device = device;
  v.record.code_first = add_code(m, p);
  v.record.code_len = static_cast<uint16_t>(p.size());
  v.record.response = response;
  v.record.reply_errno = err;
  v.record.template_id = tpl;
  v.record.commands = commands;
  m.invariants.push_back(v);
}

// A task with D = T = `period_us`.
inline Named<TaskRecord> task_rec(const char* name, uint32_t period_us, uint32_t wcet_us,
                                  uint16_t priority, uint16_t actuations_per_job) {
  Named<TaskRecord> t;
  t.name = name;
  t.record.period_us = period_us;
  t.record.deadline_us = period_us;
  t.record.wcet_us = wcet_us;
  t.record.priority = priority;
  t.record.actuations_per_job = actuations_per_job;
  return t;
}

inline FieldRecord field_rec(uint8_t offset, uint8_t nbytes, uint8_t width, uint8_t flags = 0,
                             uint8_t shift = 0) {
  return FieldRecord{offset, nbytes, shift, width, flags, {0, 0, 0}, 0};
}

// `index`: the channel of a register-map command (a safe state must name
// one); kSameIndex = the checked command's channel.
inline TemplateRecord template_rec(uint16_t command,
                                   std::initializer_list<std::pair<int, int32_t>> values = {},
                                   uint8_t index = kSameIndex) {
  TemplateRecord t{};
  t.command = command;
  t.index = index;
  for (auto [f, v] : values) {
    t.set_mask = static_cast<uint8_t>(t.set_mask | (1u << f));
    t.values[f] = v;
  }
  return t;
}

// ---------------------------------------------------------------------------
// Rover: gopigo (d0, actuator, 4-byte frames with optional 1-byte prefix) and
// line (d1, sensor, 10-byte samples of five big-endian 10-bit readings).
namespace rover {
enum Device : uint16_t { kGopigo = 0, kLine = 1 };
enum Command : uint16_t {
  kFwd = 0,
  kLeft,
  kRight,
  kStop,
  kSetLeftSpeed,
  kSetRightSpeed,
  kDigitalWrite,
  kReadRequest
};
enum Task : uint16_t { kFollower = 0, kLogger = 1, kIntruder = 2 };
enum Signal : uint16_t { kPos = 5 };
enum Template : uint16_t { kTplStop = 0, kTplRight = 1, kTplLeft = 2, kTplSpeed80 = 3 };
enum Invariant : uint16_t { kInv1 = 0, kInv2 = 1, kInv3 = 2 };
inline constexpr int32_t kWhite[5] = {767, 815, 859, 710, 700};
inline constexpr int32_t kBlack[5] = {1012, 1013, 1015, 1003, 1004};
inline constexpr int32_t kWeight[5] = {-100, -50, 0, 50, 100};

// pos = sum (raw_i - white_i) * 100 / (black_i - white_i) * w_i
inline Prog line_position() {
  Prog p;
  p.push(0);
  for (uint16_t i = 0; i < 5; ++i) {
    p.signal(i).push(kWhite[i]).op(Op::kSub).push(100).op(Op::kMul);
    p.push(kBlack[i] - kWhite[i]).op(Op::kDiv).push(kWeight[i]).op(Op::kMul).op(Op::kAdd);
  }
  p.op(Op::kReturn);
  return p;
}

// when <cond on pos> expect <command> else FAIL (static response).
inline Prog expect_when(Op compare, int32_t threshold, uint16_t expected) {
  Prog p;
  p.signal(kPos).push(threshold).op(compare);
  const size_t skip = p.jump(Op::kJumpIfZero);
  p.op(Op::kCommand).push(expected).op(Op::kEq);
  const size_t bad = p.jump(Op::kJumpIfZero);
  p.land(skip).op(Op::kPass);
  p.land(bad).op(Op::kFail);
  return p;
}

inline ImageModel model() {
  ImageModel m;
  auto task = [&](const char* name, uint32_t period, uint16_t prio) {
    m.tasks.push_back(task_rec(name, period, period / 5, prio, 3));
  };
  task("follower", 200000, 2);
  task("logger", 100000, 1);
  task("intruder", 50000, 3);

  // Both boards take 4-byte frames behind a 1-byte prefix on i2c-1.
  auto board = [](const char* name, uint8_t role, uint16_t addr, uint16_t first, uint16_t count) {
    Named<DeviceRecord> d;
    d.name = name;
    d.record.role = role;
    d.record.profile = Profile::kFrame;
    d.record.bus = 1;
    d.record.addr = addr;
    d.record.command_first = first;
    d.record.command_count = count;
    d.record.frame_len = 4;
    d.record.prefix_len = 1;
    return d;
  };
  Named<DeviceRecord> gopigo = board("gopigo", kRoleActuator, 0x08, 0, 7);
  gopigo.record.safe_first = kTplStop;
  gopigo.record.safe_count = 1;
  m.devices.push_back(gopigo);

  Named<DeviceRecord> line = board("line", kRoleSensor, 0x06, 7, 1);
  DeviceRecord& l = line.record;
  l.sample_request_len = 5;
  l.sample_request[0] = 1;
  l.sample_request[1] = 3;
  l.sample_len = 10;
  l.sample_period_us = 10000;
  l.max_sample_age_us = 50000;
  l.safe_first = 0;
  m.devices.push_back(line);

  auto command = [&](const char* name, uint16_t dev, uint8_t opcode, CommandClass cls,
                     FieldList fields) {
    Named<CommandRecord> c;
    c.name = name;
    c.record.device = dev;
    c.record.command_class = cls;
    c.record.match = opcode;
    add_command(m, c, fields);
  };
  command("fwd", kGopigo, 119, CommandClass::kActuate, {});
  command("left", kGopigo, 97, CommandClass::kActuate, {});
  command("right", kGopigo, 100, CommandClass::kActuate, {});
  command("stop", kGopigo, 120, CommandClass::kActuate, {});
  command("set_left_speed", kGopigo, 70, CommandClass::kActuate, {{"speed", field_rec(1, 1, 8)}});
  command("set_right_speed", kGopigo, 71, CommandClass::kActuate, {{"speed", field_rec(1, 1, 8)}});
  command("digital_write", kGopigo, 12, CommandClass::kForbidden,
          {{"pin", field_rec(1, 1, 8)}, {"value", field_rec(2, 1, 8)}});
  command("read_request", kLine, 3, CommandClass::kQuery, {});

  for (uint16_t i = 0; i < 5; ++i) {
    Named<SignalRecord> s;
    s.name = "lf" + std::to_string(i);
    s.record.kind = SignalKind::kRaw;
    s.record.device = kLine;
    s.record.field = field_rec(static_cast<uint8_t>(2 * i), 2, 16, kFieldBigEndian);
    s.record.valid_min = 0;
    s.record.valid_max = 1023;
    m.signals.push_back(s);
  }
  const Prog pos = line_position();
  Named<SignalRecord> ps;
  ps.name = "pos";
  ps.record.kind = SignalKind::kDerived;
  ps.record.device = kNone;
  ps.record.code_first = add_code(m, pos);
  ps.record.code_len = static_cast<uint16_t>(pos.size());
  m.signals.push_back(ps);

  m.templates.push_back(template_rec(kStop));             // kTplStop
  m.templates.push_back(template_rec(kRight));            // kTplRight
  m.templates.push_back(template_rec(kLeft));             // kTplLeft
  m.templates.push_back(template_rec(kNone, {{0, 80}}));  // kTplSpeed80

  Named<RateRecord> rate;
  rate.name = "speed_per_job";
  rate.record.task = kFollower;
  rate.record.device = kGopigo;
  rate.record.max_per_job = 2;
  rate.record.commands = mask_of({kSetLeftSpeed, kSetRightSpeed});
  rate.record.response = Response::kIgnore;
  rate.record.template_id = kNone;
  m.rates.push_back(rate);

  auto invariant = [&](const char* name, const Prog& p, Response response, uint16_t tpl) {
    add_invariant(m, name, kGopigo, p, mask_of({kFwd, kLeft, kRight}), response, tpl);
  };
  invariant("INV1", expect_when(Op::kLt, -2500, kRight), Response::kFailsafe, kTplRight);
  invariant("INV2", expect_when(Op::kGt, 2500, kLeft), Response::kFailsafe, kTplLeft);
  // INV3: inside the band, expect fwd; otherwise substitute fwd (FAIL_SUBST).
  Prog inv3;
  inv3.signal(kPos).push(-2500).op(Op::kGe).signal(kPos).push(2500).op(Op::kLe).op(Op::kAnd);
  const size_t out_of_band = inv3.jump(Op::kJumpIfZero);
  inv3.op(Op::kCommand).push(kFwd).op(Op::kEq);
  const size_t bad = inv3.jump(Op::kJumpIfZero);
  inv3.land(out_of_band).op(Op::kPass);
  inv3.land(bad).op(Op::kSubstBegin, kFwd).op(Op::kFailSubst);
  invariant("INV3", inv3, Response::kIgnore, kNone);

  m.access.push_back(AccessRecord{1u << kGopigo, 1u << kLine});  // follower
  m.access.push_back(AccessRecord{0, 1u << kLine});              // logger
  m.access.push_back(AccessRecord{0, 0});                        // intruder
  return m;
}

// Line-follower sample giving readings `raw` (big-endian pairs).
inline std::vector<uint8_t> sample(const int32_t (&raw)[5]) {
  std::vector<uint8_t> s;
  for (int32_t v : raw) {
    s.push_back(static_cast<uint8_t>(v >> 8));
    s.push_back(static_cast<uint8_t>(v));
  }
  return s;
}
// Readings for a centred line (pos 0), far left (pos < -2500), far right (> 2500).
inline constexpr int32_t kCentre[5] = {767, 815, 1015, 710, 700};
inline constexpr int32_t kLineLeft[5] = {1012, 1013, 859, 710, 700};
inline constexpr int32_t kLineRight[5] = {767, 815, 859, 1003, 1004};
}  // namespace rover

// ---------------------------------------------------------------------------
// Arm: a PCA9685-like register map at 0x40 (also 0x70 all-call and general
// call), auto-increment while MODE1 bit 5 is set.
namespace arm {
enum Command : uint16_t { kMode1 = 0, kMode2, kLed, kAllLed, kPrescale, kTestMode };
enum Invariant : uint16_t { kRange = 0, kSequence = 1 };
enum Task : uint16_t { kController = 0, kOther = 1 };
inline constexpr uint16_t kArm = 0;
inline constexpr uint16_t kTplSafe = 0;    // MODE1 = 0x11 (sleep: outputs off)
inline constexpr uint16_t kTplCentre = 1;  // checked led, off = 375

inline ImageModel model(bool with_sequence = true) {
  ImageModel m;
  Named<TaskRecord> t;
  t.name = "controller";
  t.record.period_us = 20000;
  t.record.priority = 5;
  m.tasks.push_back(t);
  t.name = "other";
  t.record.priority = 1;
  m.tasks.push_back(t);

  Named<DeviceRecord> arm;
  arm.name = "arm";
  DeviceRecord& d = arm.record;
  d.role = kRoleActuator;
  d.profile = Profile::kRegisterMap;
  d.bus = 1;
  d.addr = 0x40;
  d.command_first = 0;
  d.command_count = 6;
  d.auto_increment = AutoIncrement::kBit;
  d.ai_reg = 0x00;
  d.ai_bit = 5;
  d.safe_first = kTplSafe;
  d.safe_count = 1;
  m.devices.push_back(arm);
  m.aliases.push_back(AliasRecord{1, AliasKind::kAddress, 0x70, kArm, 0});
  m.aliases.push_back(AliasRecord{1, AliasKind::kGeneralCall, 0x00, kArm, 0});

  auto command = [&](const char* name, uint8_t reg, uint8_t len, uint8_t repeat, uint8_t stride,
                     CommandClass cls, FieldList fields) {
    Named<CommandRecord> c;
    c.name = name;
    c.record.device = kArm;
    c.record.command_class = cls;
    c.record.match = reg;
    c.record.group_len = len;
    c.record.repeat = repeat;
    c.record.stride = stride;
    add_command(m, c, fields);
  };
  command("mode1", 0x00, 1, 1, 0, CommandClass::kActuate, {{"value", field_rec(0, 1, 8)}});
  command("mode2", 0x01, 1, 1, 0, CommandClass::kActuate, {{"value", field_rec(0, 1, 8)}});
  command("led", 0x06, 4, 16, 4, CommandClass::kActuate,
          {{"on", field_rec(0, 2, 13)}, {"off", field_rec(2, 2, 13)}});
  command("all_led", 0xFA, 4, 1, 0, CommandClass::kActuate,
          {{"on", field_rec(0, 2, 13)}, {"off", field_rec(2, 2, 13)}});
  command("prescale", 0xFE, 1, 1, 0, CommandClass::kActuate, {{"value", field_rec(0, 1, 8)}});
  command("test_mode", 0xFF, 1, 1, 0, CommandClass::kForbidden, {});

  m.templates.push_back(template_rec(kMode1, {{0, 0x11}}, 0));  // kTplSafe
  m.templates.push_back(template_rec(kNone, {{1, 375}}));       // kTplCentre

  auto invariant = [&](const char* name, const Prog& p, CommandMask mask, Response response,
                       uint8_t err,
                       uint16_t tpl) { add_invariant(m, name, kArm, p, mask, response, tpl, err); };
  // Range: every servo pulse is 0 (output off) or inside [150, 600]; else centre it.
  Prog range;
  range.field(1).push(0).op(Op::kEq);
  const size_t nonzero = range.jump(Op::kJumpIfZero);
  range.op(Op::kPass);
  range.land(nonzero).field(1).push(150).op(Op::kLt);
  const size_t not_low = range.jump(Op::kJumpIfZero);
  range.op(Op::kFail);
  range.land(not_low).field(1).push(600).op(Op::kGt);
  const size_t not_high = range.jump(Op::kJumpIfZero);
  range.op(Op::kFail);
  range.land(not_high).op(Op::kPass);
  invariant("servo_range", range, mask_of({kLed, kAllLed}), Response::kFailsafe, 0, kTplCentre);
  if (with_sequence) {
    // Sequence: the gripper (channel 5) alternates 420, 577, 420, ... (state word = step).
    Prog seq;
    seq.op(Op::kIndex).push(5).op(Op::kEq);
    const size_t other = seq.jump(Op::kJumpIfZero);
    seq.field(1).op(Op::kState).push(0).op(Op::kEq);
    const size_t step1 = seq.jump(Op::kJumpIfZero);
    seq.push(420).op(Op::kEq);
    const size_t bad0 = seq.jump(Op::kJumpIfZero);
    seq.push(1).op(Op::kSetState).op(Op::kPass);
    seq.land(step1).push(577).op(Op::kEq);
    const size_t bad1 = seq.jump(Op::kJumpIfZero);
    seq.push(0).op(Op::kSetState).op(Op::kPass);
    seq.land(bad0).land(bad1).op(Op::kFail);
    seq.land(other).op(Op::kPass);
    invariant("grip_sequence", seq, mask_of({kLed}), Response::kReject, 1, kNone);
  }
  m.access.push_back(AccessRecord{1u << kArm, 1u << kArm});  // controller
  m.access.push_back(AccessRecord{0, 1u << kArm});           // other: read only
  m.register_init.push_back(RegisterInitRecord{kArm, 0x00, 0x11});
  m.register_init.push_back(RegisterInitRecord{kArm, 0x01, 0x04});
  return m;
}
}  // namespace arm

// Owns a Checker on the heap (it is ~200 KiB) with a host whose sensor
// samples and audit records the test controls and inspects.
struct Harness {
  struct Sample {
    std::vector<uint8_t> bytes;
    uint64_t taken_at_us = 0;
  };
  std::unique_ptr<Checker> checker = std::make_unique<Checker>();
  std::vector<Sample> samples = std::vector<Sample>(kMaxDevices);
  std::vector<AuditRecord> audits;
  std::vector<std::vector<uint8_t>> audit_substitutes;
  uint32_t sample_reads = 0;

  Harness() {
    Host h{};
    h.context = this;
    h.read_sample = [](void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                       uint64_t* taken) -> uint32_t {
      auto* self = static_cast<Harness*>(ctx);
      ++self->sample_reads;
      const Sample& s = self->samples[device];
      if (s.bytes.size() > capacity) return 0;
      if (!s.bytes.empty()) std::memcpy(buf, s.bytes.data(), s.bytes.size());
      *taken = s.taken_at_us;
      return static_cast<uint32_t>(s.bytes.size());
    };
    h.audit = [](void* ctx, const AuditRecord* r) {
      auto* self = static_cast<Harness*>(ctx);
      self->audits.push_back(*r);
      self->audit_substitutes.emplace_back(r->substitute, r->substitute + r->substitute_len);
    };
    checker->set_host(h);
  }

  LoadResult load(const ImageModel& m) {
    const std::vector<uint8_t> bytes = image::serialize(m);
    return checker->load(bytes.data(), static_cast<uint32_t>(bytes.size()));
  }

  Verdict check(uint16_t task, uint16_t addr, std::vector<uint8_t> bytes, uint64_t now_us = 1000,
                uint32_t job = 0, TxKind kind = TxKind::kWrite, uint8_t bus = 1) {
    const Transaction tx{
        task,         bus,   kind, addr, 0, 0, job, static_cast<uint32_t>(bytes.size()),
        bytes.data(), now_us};
    Verdict v{};
    audits.clear();
    audit_substitutes.clear();
    checker->check(tx, &v);
    return v;
  }
};

// The writes of a verdict, one vector per emit.
inline std::vector<std::vector<uint8_t>> emits(const Verdict& v) {
  std::vector<std::vector<uint8_t>> out;
  uint32_t at = 0;
  for (uint32_t i = 0; i < v.emit_count; ++i) {
    out.emplace_back(v.emit_bytes + at, v.emit_bytes + at + v.emit_len[i]);
    at += v.emit_len[i];
  }
  return out;
}

// What the arm's test files share (`using namespace testing::arm_tests;`).
namespace arm_tests {
using testing::emits;
using testing::Harness;
namespace arm = testing::arm;
using Bytes = std::vector<uint8_t>;
using Writes = std::vector<Bytes>;
inline constexpr uint16_t kAddr = 0x40;
inline constexpr uint8_t kLed4 = 0x06 + 4 * 4;  // LED4_ON_L
inline constexpr uint8_t kLed5 = 0x06 + 4 * 5;  // LED5_ON_L (the gripper: sequence rule)
}  // namespace arm_tests

}  // namespace contego::core::testing

#endif  // CONTEGO_CORE_TEST_FIXTURES_H_
