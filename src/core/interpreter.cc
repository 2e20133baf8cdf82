// The bytecode interpreter and the signal evaluation behind it. Programs are
// verified at load (operands in range, forward jumps, stack depth within
// kMaxStackDepth on every path), so the loop below needs no bounds checks of
// its own; it checks only what depends on runtime values: arithmetic
// overflow, division by zero, missing fields, history and signals.
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {
namespace {

// Binary arithmetic and comparison: false on overflow or division by zero.
inline bool binary(Op op, int64_t a, int64_t b, int64_t* r) {
  switch (op) {
    case Op::kAdd:
      return !__builtin_add_overflow(a, b, r);
    case Op::kSub:
      return !__builtin_sub_overflow(a, b, r);
    case Op::kMul:
      return !__builtin_mul_overflow(a, b, r);
    case Op::kDiv:
    case Op::kMod:
      if (b == 0 || (b == -1 && a == INT64_MIN)) return false;
      *r = op == Op::kDiv ? a / b : a % b;
      return true;
    case Op::kMin:
      *r = b < a ? b : a;
      return true;
    case Op::kMax:
      *r = b > a ? b : a;
      return true;
    case Op::kEq:
      *r = a == b;
      return true;
    case Op::kNe:
      *r = a != b;
      return true;
    case Op::kLt:
      *r = a < b;
      return true;
    case Op::kLe:
      *r = a <= b;
      return true;
    case Op::kGt:
      *r = a > b;
      return true;
    case Op::kGe:
      *r = a >= b;
      return true;
    case Op::kAnd:
      *r = a != 0 && b != 0;
      return true;
    case Op::kOr:
      *r = a != 0 || b != 0;
      return true;
    default:
      return false;
  }
}

}  // namespace

// The latest sample of sensor `device`, read from the host once per check().
// Its generation moves whenever what a signal could make of it changes: the
// bytes, the length, or whether it is still fresh at `now_us`.
SampleMemo& CheckerState::sample(uint16_t device, uint64_t now_us) {
  SampleMemo& m = sample_memo_[device];
  if (m.epoch == epoch_) return m;
  m.epoch = epoch_;
  uint8_t buf[kMaxSampleBytes];
  uint32_t len = 0;
  uint64_t taken = 0;
  if (host_.read_sample != nullptr) {
    const uint32_t n = host_.read_sample(host_.context, device, buf, kMaxSampleBytes, &taken);
    len = n > kMaxSampleBytes ? 0 : n;  // a host that overran the buffer is not believed
  }
  // Compared eight bytes at a time: a sensor's sample is the same most of
  // the time, and this runs once per check.
  // The tail of a sample of 8 bytes or more is its last 8 bytes, which
  // overlap the words before: no byte loop.
  uint64_t diff = len != m.len ? 1 : 0;
  auto word_diff = [&](uint32_t at) {
    uint64_t was = 0;
    uint64_t now = 0;
    __builtin_memcpy(&was, m.bytes + at, 8);
    __builtin_memcpy(&now, buf + at, 8);
    return was ^ now;
  };
  if (len >= 8) {
    for (uint32_t i = 0; i + 8 <= len; i += 8) diff |= word_diff(i);
    diff |= word_diff(len - 8);
  } else {
    for (uint32_t i = 0; i < len; ++i) diff |= static_cast<uint8_t>(m.bytes[i] ^ buf[i]);
  }
  bool changed = diff != 0;
  if (changed) __builtin_memcpy(m.bytes, buf, len);
  m.len = len;
  m.taken_at_us = len != 0 ? taken : 0;
  const uint64_t max_age = devices_[device].max_sample_age_us;
  const uint64_t age = now_us > m.taken_at_us ? now_us - m.taken_at_us : 0;
  const bool fresh = max_age == 0 || age <= max_age;
  if (fresh != m.fresh) changed = true;
  m.fresh = fresh;
  if (changed) ++m.generation;
  return m;
}

static_assert(kMaxDevices <= 32, "signal_devices_ holds one bit per device");

SignalStatus CheckerState::raw_signal(uint16_t id, uint64_t now_us, int64_t* value) {
  const SignalRecord& s = signals_[id];
  const SampleMemo& m = sample(s.device, now_us);
  if (m.len == 0 || s.field.offset + s.field.nbytes > m.len) return SignalStatus::kUnavailable;
  if (!m.fresh) return SignalStatus::kUnavailable;
  const int32_t v = field_get(s.field, m.bytes);
  if (v < s.valid_min || v > s.valid_max) return SignalStatus::kUnavailable;
  *value = v;
  return SignalStatus::kOk;
}

// Memoised per check(). A derived signal first evaluates, in ascending id
// order, every derived signal it depends on, so programs never recurse.
// A derived program reads nothing but signals and constants, so its result is
// also kept across checks while every sensor it can reach holds the same
// sample bytes and the same freshness (docs/core.md, "Signals").
SignalStatus CheckerState::signal(uint16_t id, uint64_t now_us, int64_t* value) {
  SignalMemo& memo = signal_memo_[id];
  if (memo.epoch != epoch_) {
    if (signals_[id].kind == SignalKind::kRaw) {
      int64_t v = 0;
      memo.status = raw_signal(id, now_us, &v);
      memo.value = v;
      memo.epoch = epoch_;
    } else {
      uint64_t todo = signal_deps_[id] | (uint64_t{1} << id);
      while (todo != 0) {
        const uint32_t s = static_cast<uint32_t>(__builtin_ctzll(todo));
        todo &= todo - 1;
        SignalMemo& m = signal_memo_[s];
        if (m.epoch == epoch_) continue;
        uint64_t inputs = 0;
        for (uint32_t devs = signal_devices_[s]; devs != 0; devs &= devs - 1) {
          inputs += sample(static_cast<uint16_t>(__builtin_ctz(devs)), now_us).generation;
        }
        m.epoch = epoch_;
        if (m.kept && m.inputs == inputs) continue;
        const SignalRecord& rec = signals_[s];
        int64_t v = 0;
        const Env env{nullptr, nullptr, kNone, nullptr};
        const Exit exit = run(rec.code_first, rec.code_len, env, &v);
        m.status = exit == Exit::kReturn        ? SignalStatus::kOk
                   : exit == Exit::kUnavailable ? SignalStatus::kUnavailable
                                                : SignalStatus::kFault;
        m.value = v;
        m.kept = true;
        m.inputs = inputs;
      }
    }
  }
  *value = memo.value;
  return memo.status;
}

// What SIGNAL reads: this check's memo when it is current (most programs of
// a check read the same signals), else the signal evaluated.
inline SignalStatus CheckerState::signal_now(uint16_t id, int64_t* value) {
  const SignalMemo& memo = signal_memo_[id];
  if (memo.epoch != epoch_) return signal(id, now_us_, value);
  *value = memo.value;
  return memo.status;
}

// The values a program reads from the task's job count and the command's
// history (run() reads the command's own values itself). False: a fault (no
// history yet, no such field).
bool CheckerState::context_value(const Insn& in, const Env& env, int64_t* v) {
  switch (in.op) {
    case Op::kJobCount:
      *v = job_count_[env.tx->task][env.d->device];
      return true;
    case Op::kLastField: {
      const LastCommand& l = last(env.d->command, env.d->index);
      if (!l.valid || in.b >= commands_[env.d->command].field_count) return false;
      *v = l.fields[in.b];
      return true;
    }
    case Op::kSinceLast: {
      const LastCommand& l = last(env.d->command, env.d->index);
      if (!l.valid) return false;
      const uint64_t dt = now_us_ > l.time_us ? now_us_ - l.time_us : 0;
      if (dt > 0x7FFFFFFFFFFFFFFFull) return false;
      *v = static_cast<int64_t>(dt);
      return true;
    }
    case Op::kHasLast:
      *v = last(env.d->command, env.d->index).valid ? 1 : 0;
      return true;
    default:
      return false;
  }
}

// SUBST_BEGIN / SUBST_FIELD (`v` is the popped value). False: a fault.
bool CheckerState::subst_op(const Insn& in, const Env& env, int64_t v) {
  Subst& s = *env.subst;
  if (in.op == Op::kSubstBegin) {
    s.active = true;
    s.command = in.b == kNone ? env.d->command : in.b;
    s.index = kSameIndex;
    s.set_mask = 0;
    __builtin_memset(s.values, 0, sizeof(s.values));
    return true;
  }
  if (!s.active || in.b >= commands_[s.command].field_count || v < INT32_MIN || v > INT32_MAX) {
    return false;
  }
  s.values[in.b] = static_cast<int32_t>(v);
  s.set_mask = static_cast<uint8_t>(s.set_mask | (1u << in.b));
  return true;
}

namespace {

// The operand stack: the top lives in `tos` (a register once inlined); `below`
// holds the rest above a dummy bottom slot, so a push never tests for an
// empty stack (the verifier proved the depth on every path).
struct OperandStack {
  int64_t below[kMaxStackDepth + 1];
  uint32_t sp = 0;
  int64_t tos = 0;
  __attribute__((always_inline)) void push(int64_t v) {
    below[sp++] = tos;
    tos = v;
  }
  __attribute__((always_inline)) int64_t pop() {
    const int64_t v = tos;
    tos = below[--sp];
    return v;
  }
  // a `op` b with b on top: false on overflow or division by zero.
  __attribute__((always_inline)) bool arith(Op op) {
    const int64_t a = below[--sp];
    return binary(op, a, tos, &tos);
  }
};

}  // namespace

// One case per binary operator, so that `binary` folds to its one operation
// (a shared case would switch on the operator a second time).
#define CONTEGO_BINARY_CASE(name)             \
  case Op::k##name:                           \
    if (!stack.arith(Op::k##name)) goto done; \
    break
#define CONTEGO_BINARY_CASES \
  CONTEGO_BINARY_CASE(Add);  \
  CONTEGO_BINARY_CASE(Sub);  \
  CONTEGO_BINARY_CASE(Mul);  \
  CONTEGO_BINARY_CASE(Div);  \
  CONTEGO_BINARY_CASE(Mod);  \
  CONTEGO_BINARY_CASE(Min);  \
  CONTEGO_BINARY_CASE(Max);  \
  CONTEGO_BINARY_CASE(Eq);   \
  CONTEGO_BINARY_CASE(Ne);   \
  CONTEGO_BINARY_CASE(Lt);   \
  CONTEGO_BINARY_CASE(Le);   \
  CONTEGO_BINARY_CASE(Gt);   \
  CONTEGO_BINARY_CASE(Ge);   \
  CONTEGO_BINARY_CASE(And);  \
  CONTEGO_BINARY_CASE(Or)

// One case per compare for each kind of superinstruction (Fused).
#define CONTEGO_FOR_EACH_COMPARE(CASE) \
  CASE(Eq, ==);                        \
  CASE(Ne, !=);                        \
  CASE(Lt, <);                         \
  CASE(Le, <=);                        \
  CASE(Gt, >);                         \
  CASE(Ge, >=)

// x <op> imm, then the jump when false: after the fetch, ip is at the
// compare; the jump's target is off past the JZ (two further on).
#define CONTEGO_FUSED_CASE(name, compare)                       \
  case static_cast<Op>(Fused::k##name##Jz): {                   \
    steps += 2;                                                 \
    const int64_t x = stack.pop();                              \
    ip += (x compare int64_t{in.imm}) ? 2 : uint32_t{in.b} + 1; \
    break;                                                      \
  }

// The signal first (as SIGNAL: a missing one ends the program), then the
// compare; ip is at the PUSH, the jump's target off past the JZ.
#define CONTEGO_FUSED_SIGNAL_CASE(name, compare)                                   \
  case static_cast<Op>(Fused::k##name##SignalJz): {                                \
    int64_t v = 0;                                                                 \
    const SignalStatus st = signal_now(in.b, &v);                                  \
    if (st != SignalStatus::kOk) {                                                 \
      exit = st == SignalStatus::kUnavailable ? Exit::kUnavailable : Exit::kFault; \
      goto done;                                                                   \
    }                                                                              \
    steps += 3;                                                                    \
    ip += (v compare int64_t{in.imm}) ? 3 : uint32_t{in.a} + 2;                    \
    break;                                                                         \
  }

// The checked command's id compared with imm: ip is at the PUSH.
#define CONTEGO_FUSED_COMMAND_CASE(name, compare)                                     \
  case static_cast<Op>(Fused::k##name##CommandJz):                                    \
    steps += 3;                                                                       \
    ip += (int64_t{env.d->command} compare int64_t{in.imm}) ? 3 : uint32_t{in.a} + 2; \
    break

// The checked command's field b compared with imm (a missing field ends the
// program, as FIELD): ip is at the PUSH.
#define CONTEGO_FUSED_FIELD_CASE(name, compare)                                            \
  case static_cast<Op>(Fused::k##name##FieldJz):                                           \
    if (env.d == nullptr || in.b >= env.d->field_count) goto done;                         \
    steps += 3;                                                                            \
    ip += (int64_t{env.d->fields[in.b]} compare int64_t{in.imm}) ? 3 : uint32_t{in.a} + 2; \
    break

// The loader verified every program: operands in range, valid opcodes, forward
// jumps inside the program, the stack depth on every path, and no path that
// runs past the end without a terminator (PASS, FAIL, FAIL_SUBST, RETURN or a
// jump). So the loop has no bounds check of its own, and each opcode has its
// own case (binary operators too, so that `binary` folds to one operation): it
// checks only what depends on values.
// The switch below has cases for the loader's own opcodes (Fused), which
// are not in Op.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wswitch"
Exit CheckerState::run(uint16_t code_first, uint16_t code_len, const Env& env, int64_t* result) {
  (void)code_len;  // the verifier proved no path reaches it
  OperandStack stack;
  int64_t& tos = stack.tos;
  const Insn* ip = code_ + code_first;
  uint32_t steps = 0;  // instructions executed, added to executed_ on every exit
  Exit exit = Exit::kFault;
  for (;;) {
    const Insn& in = *ip++;
    ++steps;
    switch (in.op) {
      case Op::kNop:
        break;
      case Op::kPush:
        stack.push(in.imm);
        break;
      case Op::kPushConst:
        stack.push(constants_[in.b]);
        break;
      case Op::kSignal: {
        int64_t v = 0;
        const SignalStatus st = signal_now(in.b, &v);
        stack.push(v);
        if (st == SignalStatus::kOk) break;
        exit = st == SignalStatus::kUnavailable ? Exit::kUnavailable : Exit::kFault;
        goto done;
      }
      case Op::kField:
        if (env.d == nullptr || in.b >= env.d->field_count) goto done;
        stack.push(env.d->fields[in.b]);
        break;
      case Op::kCommand:
        stack.push(env.d->command);
        break;
      case Op::kIndex:
        stack.push(env.d->index);
        break;
      case Op::kState:
        stack.push(bit_test(tx_.pending_state, env.invariant)
                       ? pending_state_[env.invariant]
                       : state_word(env.invariant, env.tx->task));
        break;
      case Op::kJobCount:
      case Op::kLastField:
      case Op::kSinceLast:
      case Op::kHasLast: {
        int64_t v = 0;
        if (!context_value(in, env, &v)) goto done;
        stack.push(v);
        break;
      }
      case Op::kSetState:
        pending_state_[env.invariant] = stack.pop();
        bit_set(tx_.pending_state, env.invariant);
        tx_.any_pending = true;
        break;
        CONTEGO_BINARY_CASES;
      case Op::kNeg:
      case Op::kAbs:
        if (tos == INT64_MIN) goto done;
        if (in.op == Op::kNeg || tos < 0) tos = -tos;
        break;
      case Op::kNot:
        tos = tos == 0;
        break;
      case Op::kDup:
        stack.push(tos);
        break;
      case Op::kDrop:
        stack.pop();
        break;
      case Op::kJumpIfZero:
        if (stack.pop() == 0) ip += in.imm - 1;
        break;
      case Op::kJump:
        ip += in.imm - 1;
        break;
      case Op::kSubstBegin:
        if (!subst_op(in, env, 0)) goto done;
        break;
      case Op::kSubstField:
        if (!subst_op(in, env, stack.pop())) goto done;
        break;
        CONTEGO_FOR_EACH_COMPARE(CONTEGO_FUSED_CASE);
        CONTEGO_FOR_EACH_COMPARE(CONTEGO_FUSED_SIGNAL_CASE);
        CONTEGO_FOR_EACH_COMPARE(CONTEGO_FUSED_COMMAND_CASE);
        CONTEGO_FOR_EACH_COMPARE(CONTEGO_FUSED_FIELD_CASE);
      case Op::kPass:
        exit = Exit::kPass;
        goto done;
      case Op::kFail:
        exit = Exit::kFail;
        goto done;
      case Op::kFailSubst:
        if (env.subst->active) exit = Exit::kFailSubst;
        goto done;
      case Op::kReturn:
        *result = tos;
        exit = Exit::kReturn;
        goto done;
      default:
        __builtin_unreachable();  // the verifier refused every other opcode
    }
  }
done:
  executed_ += steps;
  return exit;
}
#pragma GCC diagnostic pop

#undef CONTEGO_BINARY_CASE
#undef CONTEGO_BINARY_CASES
#undef CONTEGO_FUSED_CASE
#undef CONTEGO_FUSED_SIGNAL_CASE
#undef CONTEGO_FUSED_COMMAND_CASE
#undef CONTEGO_FUSED_FIELD_CASE
#undef CONTEGO_FOR_EACH_COMPARE

static_assert(kMaxProgramLength <= 0xFFFF, "a fused jump offset lives in Insn::b");

// Whether [at, at + len) lies inside every program that holds `at` (and
// some program holds it): a superinstruction must not read past the end of
// any program that can reach it.
bool CheckerState::inside_every_program(uint32_t at, uint32_t len) const {
  bool held = false;
  auto check = [&](uint32_t first, uint32_t n) {
    if (at < first || at >= first + n) return true;
    held = true;
    return at + len <= first + n;
  };
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (!check(invariants_[i].code_first, invariants_[i].code_len)) return false;
  }
  for (uint32_t s = 0; s < signal_count_; ++s) {
    if (signals_[s].kind == SignalKind::kRaw) continue;
    if (!check(signals_[s].code_first, signals_[s].code_len)) return false;
  }
  return held;
}

// `PUSH imm; <compare>; JZ off` -- a threshold test, the most common shape
// of an invariant -- becomes one instruction at the PUSH, three dispatches
// and two stack moves fewer (core_bench). The compare and the jump stay
// where they are, for jumps that land on them; the verifier and the costs
// saw the image's own instructions, and executed_instructions() still counts
// three.
void CheckerState::fuse_programs() {
  for (uint32_t i = 0; i + 2 < code_count_; ++i) {
    Insn& push = code_[i];
    const Insn& compare = code_[i + 1];
    const Insn& jump = code_[i + 2];
    if (push.op != Op::kPush || jump.op != Op::kJumpIfZero) continue;
    // Eq..Ge are consecutive in Op, and their fused forms in Fused.
    static_assert(static_cast<int>(Op::kGe) - static_cast<int>(Op::kEq) ==
                  static_cast<int>(Fused::kGeJz) - static_cast<int>(Fused::kEqJz));
    if (compare.op < Op::kEq || compare.op > Op::kGe || !inside_every_program(i, 3)) continue;
    push.op = static_cast<Op>(static_cast<int>(Fused::kEqJz) + static_cast<int>(compare.op) -
                              static_cast<int>(Op::kEq));
    push.b = static_cast<uint16_t>(jump.imm);  // verified: 1 <= imm < the program's length
  }
  // A signal read, the command's id or one of its fields right before such a
  // compare (a threshold on a reading, a test of which command this is, a
  // field's bound) joins it, when the jump's offset fits in Insn::a.
  for (uint32_t i = 0; i + 3 < code_count_; ++i) {
    Insn& value = code_[i];
    const Insn& fused = code_[i + 1];
    int shift = 0;  // from the k*Jz to the joined form
    if (value.op == Op::kSignal) shift = 0x10;
    if (value.op == Op::kCommand) shift = -0x10;
    if (value.op == Op::kField) shift = -0x20;
    const auto fused_op = static_cast<uint8_t>(fused.op);
    if (shift == 0 || fused_op < static_cast<uint8_t>(Fused::kEqJz) ||
        fused_op > static_cast<uint8_t>(Fused::kGeJz) || fused.b > 0xFF ||
        !inside_every_program(i, 4)) {
      continue;
    }
    // The joined form of the same compare; b keeps the signal's id or the field.
    value.op = static_cast<Op>(fused_op + shift);
    value.a = static_cast<uint8_t>(fused.b);
    value.imm = fused.imm;
  }
}

}  // namespace contego::core::internal
