// The bytecode interpreter and the signal evaluation behind it. Programs are
// verified at load (operands in range, forward jumps, stack depth within
// kMaxStackDepth on every path), so the loop below needs no bounds checks of
// its own; it checks only what depends on runtime values: arithmetic
// overflow, division by zero, missing fields, history and signals.
#include "contego/core/checker.h"

#include "core/internal.h"

namespace contego::core {
namespace {

constexpr uint8_t kOk = 0;
constexpr uint8_t kUnavailable = 1;
constexpr uint8_t kFault = 2;

}  // namespace

// The latest sample of sensor `device`, read from the host once per check().
// Its generation moves whenever what a signal could make of it changes: the
// bytes, the length, or whether it is still fresh at `now_us`.
Checker::SampleMemo& Checker::sample(uint16_t device, uint64_t now_us) {
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
  bool changed = len != m.len;
  for (uint32_t i = 0; i < len; ++i) {
    if (m.bytes[i] != buf[i]) {
      m.bytes[i] = buf[i];
      changed = true;
    }
  }
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

uint8_t Checker::raw_signal(uint16_t id, uint64_t now_us, int64_t* value) {
  const SignalRecord& s = signals_[id];
  const SampleMemo& m = sample(s.device, now_us);
  if (m.len == 0 || static_cast<uint32_t>(s.field.offset) + s.field.nbytes > m.len) {
    return kUnavailable;
  }
  if (!m.fresh) return kUnavailable;
  const int32_t v = internal::field_get(s.field, m.bytes);
  if (v < s.valid_min || v > s.valid_max) return kUnavailable;
  *value = v;
  return kOk;
}

// Memoised per check(). A derived signal first evaluates, in ascending id
// order, every derived signal it depends on, so programs never recurse.
// A derived program reads nothing but signals and constants, so its result is
// also kept across checks while every sensor it can reach holds the same
// sample bytes and the same freshness (docs/core.md, "Signals").
uint8_t Checker::signal(uint16_t id, uint64_t now_us, int64_t* value) {
  SignalMemo& memo = signal_memo_[id];
  if (memo.epoch != epoch_) {
    if (signals_[id].kind == static_cast<uint8_t>(SignalKind::kRaw)) {
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
        uint8_t status = kOk;
        const Env env{nullptr, nullptr, kNone, nullptr};
        const uint8_t term = run(rec.code_first, rec.code_len, env, &v, &status);
        m.status = term == static_cast<uint8_t>(Op::kReturn) ? kOk : status;
        m.value = v;
        m.kept = true;
        m.inputs = inputs;
      }
    }
  }
  *value = memo.value;
  return memo.status;
}

uint8_t Checker::run(uint16_t code_first, uint16_t code_len, const Env& env, int64_t* result,
                     uint8_t* status) {
  int64_t stack[kMaxStackDepth];
  uint32_t sp = 0;
  const Insn* prog = code_ + code_first;
  uint32_t pc = 0;
  uint32_t steps = 0;
  *status = kFault;
  // Every exit adds the instructions this run executed to executed_.
  struct Count {
    uint64_t& total;
    const uint32_t& steps;
    ~Count() { total += steps; }
  } count{executed_, steps};
#define FAULT()       \
  do {                \
    *status = kFault; \
    return 0;         \
  } while (0)
  while (pc < code_len) {
    const Insn& in = prog[pc];
    ++steps;
    switch (static_cast<Op>(in.op)) {
      case Op::kNop:
        break;
      case Op::kPush:
        stack[sp++] = in.imm;
        break;
      case Op::kPushConst:
        stack[sp++] = constants_[in.b];
        break;
      case Op::kSignal: {
        int64_t v = 0;
        const uint8_t st = signal(in.b, now_us_, &v);
        if (st != kOk) {
          *status = st;
          return 0;
        }
        stack[sp++] = v;
        break;
      }
      case Op::kField:
        if (env.d == nullptr || in.b >= env.d->field_count) FAULT();
        stack[sp++] = env.d->fields[in.b];
        break;
      case Op::kCommand:
        stack[sp++] = env.d->command;
        break;
      case Op::kIndex:
        stack[sp++] = env.d->index;
        break;
      case Op::kJobCount:
        stack[sp++] = job_count_[env.tx->task][env.d->device];
        break;
      case Op::kLastField: {
        const LastCommand& l = last(env.d->command, env.d->index);
        if (!l.valid || in.b >= commands_[env.d->command].field_count) FAULT();
        stack[sp++] = l.fields[in.b];
        break;
      }
      case Op::kSinceLast: {
        const LastCommand& l = last(env.d->command, env.d->index);
        if (!l.valid) FAULT();
        const uint64_t dt = now_us_ > l.time_us ? now_us_ - l.time_us : 0;
        if (dt > 0x7FFFFFFFFFFFFFFFull) FAULT();
        stack[sp++] = static_cast<int64_t>(dt);
        break;
      }
      case Op::kHasLast:
        stack[sp++] = last(env.d->command, env.d->index).valid ? 1 : 0;
        break;
      case Op::kState:
        stack[sp++] = internal::bit_test(tx_.pending_state, env.invariant)
                          ? pending_state_[env.invariant]
                          : state_words_[env.invariant];
        break;
      case Op::kSetState:
        pending_state_[env.invariant] = stack[--sp];
        internal::bit_set(tx_.pending_state, env.invariant);
        break;
      case Op::kAdd:
        --sp;
        if (__builtin_add_overflow(stack[sp - 1], stack[sp], &stack[sp - 1])) FAULT();
        break;
      case Op::kSub:
        --sp;
        if (__builtin_sub_overflow(stack[sp - 1], stack[sp], &stack[sp - 1])) FAULT();
        break;
      case Op::kMul:
        --sp;
        if (__builtin_mul_overflow(stack[sp - 1], stack[sp], &stack[sp - 1])) FAULT();
        break;
      case Op::kDiv:
      case Op::kMod: {
        --sp;
        const int64_t b = stack[sp];
        const int64_t a = stack[sp - 1];
        if (b == 0 || (b == -1 && a == INT64_MIN)) FAULT();
        stack[sp - 1] = static_cast<Op>(in.op) == Op::kDiv ? a / b : a % b;
        break;
      }
      case Op::kNeg:
        if (stack[sp - 1] == INT64_MIN) FAULT();
        stack[sp - 1] = -stack[sp - 1];
        break;
      case Op::kAbs:
        if (stack[sp - 1] == INT64_MIN) FAULT();
        if (stack[sp - 1] < 0) stack[sp - 1] = -stack[sp - 1];
        break;
      case Op::kMin:
        --sp;
        if (stack[sp] < stack[sp - 1]) stack[sp - 1] = stack[sp];
        break;
      case Op::kMax:
        --sp;
        if (stack[sp] > stack[sp - 1]) stack[sp - 1] = stack[sp];
        break;
      case Op::kEq:
        --sp;
        stack[sp - 1] = stack[sp - 1] == stack[sp];
        break;
      case Op::kNe:
        --sp;
        stack[sp - 1] = stack[sp - 1] != stack[sp];
        break;
      case Op::kLt:
        --sp;
        stack[sp - 1] = stack[sp - 1] < stack[sp];
        break;
      case Op::kLe:
        --sp;
        stack[sp - 1] = stack[sp - 1] <= stack[sp];
        break;
      case Op::kGt:
        --sp;
        stack[sp - 1] = stack[sp - 1] > stack[sp];
        break;
      case Op::kGe:
        --sp;
        stack[sp - 1] = stack[sp - 1] >= stack[sp];
        break;
      case Op::kAnd:
        --sp;
        stack[sp - 1] = (stack[sp - 1] != 0) && (stack[sp] != 0);
        break;
      case Op::kOr:
        --sp;
        stack[sp - 1] = (stack[sp - 1] != 0) || (stack[sp] != 0);
        break;
      case Op::kNot:
        stack[sp - 1] = stack[sp - 1] == 0;
        break;
      case Op::kDup:
        stack[sp] = stack[sp - 1];
        ++sp;
        break;
      case Op::kDrop:
        --sp;
        break;
      case Op::kJumpIfZero:
        if (stack[--sp] == 0) {
          pc += static_cast<uint32_t>(in.imm);
          continue;
        }
        break;
      case Op::kJump:
        pc += static_cast<uint32_t>(in.imm);
        continue;
      case Op::kSubstBegin: {
        Subst& s = *env.subst;
        s.active = true;
        s.command = in.b == kNone ? env.d->command : in.b;
        s.index = kSameIndex;
        s.set_mask = 0;
        for (uint32_t i = 0; i < kMaxFieldsPerCommand; ++i) s.values[i] = 0;
        break;
      }
      case Op::kSubstField: {
        Subst& s = *env.subst;
        const int64_t v = stack[--sp];
        if (!s.active || in.b >= commands_[s.command].field_count || v < INT32_MIN ||
            v > INT32_MAX) {
          FAULT();
        }
        s.values[in.b] = static_cast<int32_t>(v);
        s.set_mask = static_cast<uint8_t>(s.set_mask | (1u << in.b));
        break;
      }
      case Op::kPass:
      case Op::kFail:
        *status = kOk;
        return in.op;
      case Op::kFailSubst:
        if (!env.subst->active) FAULT();
        *status = kOk;
        return in.op;
      case Op::kReturn:
        *result = stack[sp - 1];
        *status = kOk;
        return in.op;
      default:
        FAULT();
    }
    ++pc;
  }
#undef FAULT
  return 0;
}

}  // namespace contego::core
