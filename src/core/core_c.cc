// The C ABI facade (include/contego/core_c.h) over Checker. The C structs
// mirror the C++ ones field for field; static_asserts keep them in step.
// Every entry point checks its pointers: a NULL checker or transaction
// fails closed, a NULL output is left alone.
#include "contego/core_c.h"

#include <stddef.h>

#include "contego/core/checker.h"

namespace core = contego::core;

// The C structs are the C++ ones, field for field: same offsets and sizes.
// SAME_FIELDS(C, CPP, f...) asserts each field f in turn (C++20 __VA_OPT__).
#define SAME_FIELD(C, CPP, f)                                   \
  static_assert(offsetof(C, f) == offsetof(CPP, f), #C "." #f); \
  static_assert(sizeof(C::f) == sizeof(CPP::f), #C "." #f " size");
#define SAME_PARENS ()
#define SAME_EXPAND(...) SAME_EXPAND2(SAME_EXPAND2(SAME_EXPAND2(SAME_EXPAND2(__VA_ARGS__))))
#define SAME_EXPAND2(...) SAME_EXPAND1(SAME_EXPAND1(SAME_EXPAND1(SAME_EXPAND1(__VA_ARGS__))))
#define SAME_EXPAND1(...) __VA_ARGS__
#define SAME_NEXT() SAME_EACH
#define SAME_EACH(C, CPP, f, ...) \
  SAME_FIELD(C, CPP, f) __VA_OPT__(SAME_NEXT SAME_PARENS(C, CPP, __VA_ARGS__))
#define SAME_FIELDS(C, CPP, ...)                                             \
  static_assert(sizeof(C) == sizeof(CPP) && alignof(C) == alignof(CPP), #C); \
  SAME_EXPAND(SAME_EACH(C, CPP, __VA_ARGS__))

SAME_FIELDS(contego_transaction, core::Transaction, task, bus, kind, addr, ten_bit, pad, job, len,
            bytes, now_us)
SAME_FIELDS(contego_verdict, core::Verdict, decision, reason, rule_kind, reply_errno, rule, device,
            addr, bus, emit_count, emit_bytes_used, emit_len, emit_bytes)
SAME_FIELDS(contego_audit_record, core::AuditRecord, time_us, job, task, device, command, rule,
            rule_kind, decision, reason, index, fields, field_count, bus, addr, original_len,
            substitute_len, original, substitute)

static_assert(CONTEGO_MAX_EMITS == core::kMaxEmits);
static_assert(CONTEGO_ROLE_ACTUATOR == core::kRoleActuator &&
              CONTEGO_ROLE_SENSOR == core::kRoleSensor);
static_assert(CONTEGO_MAX_EMIT_BYTES == core::kMaxEmitBytes);
static_assert(CONTEGO_MAX_FIELDS == core::kMaxFieldsPerCommand);
static_assert(CONTEGO_NONE == core::kNone);
static_assert(CONTEGO_ALLOW == static_cast<int>(core::Decision::kAllow) &&
              CONTEGO_IGNORE == static_cast<int>(core::Decision::kIgnore) &&
              CONTEGO_FAILSAFE == static_cast<int>(core::Decision::kFailsafe) &&
              CONTEGO_REJECT == static_cast<int>(core::Decision::kReject));
static_assert(CONTEGO_TX_WRITE == static_cast<int>(core::TxKind::kWrite) &&
              CONTEGO_TX_READ == static_cast<int>(core::TxKind::kRead) &&
              CONTEGO_TX_QUICK == static_cast<int>(core::TxKind::kQuick));

// Placement new without <new>: the freestanding core has no libstdc++ headers.
inline void* operator new(size_t, void* where, int /*tag*/) noexcept { return where; }

namespace {

constexpr uint8_t kEperm = 1;
constexpr uint8_t kEinval = 22;

// The caller's storage holds the checker and the C host it installed; the
// core's Host points at small trampolines that hand the C callbacks C types.
struct Facade {
  core::Checker checker;
  contego_host host;
};

core::Checker* checker(contego_checker* c) { return &reinterpret_cast<Facade*>(c)->checker; }
const core::Checker* checker(const contego_checker* c) {
  return &reinterpret_cast<const Facade*>(c)->checker;
}

uint32_t read_sample_trampoline(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                                uint64_t* taken_at_us) {
  const contego_host* h = static_cast<const contego_host*>(context);
  return h->read_sample(h->context, device, buf, capacity, taken_at_us);
}

void audit_trampoline(void* context, const core::AuditRecord* record) {
  const contego_host* h = static_cast<const contego_host*>(context);
  // Layout-identical (asserted above).
  h->audit(h->context, reinterpret_cast<const contego_audit_record*>(record));
}

}  // namespace

extern "C" {

size_t contego_checker_size(void) { return sizeof(Facade); }
size_t contego_checker_align(void) { return alignof(Facade); }

contego_checker* contego_checker_init(void* mem, size_t size) {
  if (mem == nullptr || size < sizeof(Facade) ||
      reinterpret_cast<uintptr_t>(mem) % alignof(Facade) != 0) {
    return nullptr;
  }
  __builtin_memset(mem, 0, sizeof(Facade));
  return reinterpret_cast<contego_checker*>(new (mem, 0) Facade());
}

contego_load_result contego_load(contego_checker* c, const uint8_t* image, uint32_t size) {
  if (c == nullptr)
    return contego_load_result{static_cast<uint8_t>(core::LoadStatus::kTooSmall), 0, 0};
  const core::LoadResult r = checker(c)->load(image, size);
  return contego_load_result{static_cast<uint8_t>(r.status), r.section, r.index};
}

void contego_set_host(contego_checker* c, const contego_host* host) {
  if (c == nullptr) return;
  Facade* f = reinterpret_cast<Facade*>(c);
  core::Host h{};
  if (host != nullptr) {
    f->host = *host;
    h.context = &f->host;
    h.read_sample = host->read_sample != nullptr ? read_sample_trampoline : nullptr;
    h.audit = host->audit != nullptr ? audit_trampoline : nullptr;
  }
  f->checker.set_host(h);
}

void contego_check(contego_checker* c, const contego_transaction* tx, contego_verdict* out) {
  if (out == nullptr) return;
  if (c == nullptr || tx == nullptr) {
    // Fail closed, as the checker does for a transaction it cannot decide.
    __builtin_memset(out, 0, sizeof(*out));
    out->decision = CONTEGO_REJECT;
    out->reason =
        static_cast<uint8_t>(c == nullptr ? core::Reason::kNotLoaded : core::Reason::kMalformed);
    out->reply_errno = c == nullptr ? kEperm : kEinval;
    out->rule = CONTEGO_NONE;
    out->device = CONTEGO_NONE;
    return;
  }
  checker(c)->check(*reinterpret_cast<const core::Transaction*>(tx),
                    reinterpret_cast<core::Verdict*>(out));
}

int contego_safe_state(contego_checker* c, uint16_t device, contego_verdict* out) {
  if (c == nullptr || out == nullptr) return 0;
  return checker(c)->safe_state(device, reinterpret_cast<core::Verdict*>(out)) ? 1 : 0;
}

int contego_preview_safe_state(contego_checker* c, uint16_t device, contego_verdict* out) {
  if (c == nullptr || out == nullptr) return 0;
  return checker(c)->safe_state(device, reinterpret_cast<core::Verdict*>(out), false) ? 1 : 0;
}

void contego_begin_transfer(contego_checker* c) {
  if (c != nullptr) checker(c)->begin_transfer();
}
void contego_commit_transfer(contego_checker* c) {
  if (c != nullptr) checker(c)->commit_transfer();
}
void contego_abort_transfer(contego_checker* c, uint8_t decision) {
  if (c == nullptr) return;
  // An unknown decision is recorded as the strictest one.
  checker(c)->abort_transfer(
      static_cast<core::Decision>(decision <= CONTEGO_REJECT ? decision : uint8_t{CONTEGO_REJECT}));
}

uint8_t contego_combine_transfer(const contego_verdict* verdicts, uint32_t count,
                                 uint32_t* decider) {
  if (verdicts == nullptr && count != 0) {  // nothing to read: refuse the transfer
    if (decider != nullptr) *decider = 0;
    return static_cast<uint8_t>(core::TransferAction::kRefuse);
  }
  const core::TransferVerdict t =
      core::combine_transfer(reinterpret_cast<const core::Verdict*>(verdicts), count);
  if (decider != nullptr) *decider = t.decider;
  return static_cast<uint8_t>(t.action);
}

void contego_reset_latch(contego_checker* c, uint16_t device) {
  if (c != nullptr) checker(c)->reset_latch(device);
}

void contego_record_counts_of(const contego_checker* c, contego_record_counts* out) {
  if (out == nullptr) return;
  const core::Checker::RecordCounts n =
      c != nullptr ? checker(c)->record_counts() : core::Checker::RecordCounts{0, 0, 0, 0, 0};
  *out = {n.tasks, n.devices, n.commands, n.rates, n.invariants};
}

int contego_carry_from(contego_checker* c, const contego_checker* old, const contego_carry_map* map,
                       uint32_t* staged_dropped) {
  if (c == nullptr || old == nullptr || map == nullptr) return 0;
  const core::Checker::CarryResult r = checker(c)->carry_from(
      *checker(old), {map->tasks, map->devices, map->commands, map->rates, map->invariants});
  if (r.ok && staged_dropped != nullptr) *staged_dropped = r.staged_dropped;
  return r.ok ? 1 : 0;
}

uint32_t contego_end_session(contego_checker* c, uint16_t task) {
  return c != nullptr ? checker(c)->end_session(task) : 0;
}

uint32_t contego_command_registers(const contego_checker* c, uint16_t device, uint8_t* regs) {
  return c != nullptr && regs != nullptr ? checker(c)->command_registers(device, regs) : 0;
}

int contego_seed_register(contego_checker* c, uint16_t device, uint8_t reg, uint8_t value) {
  return c != nullptr && checker(c)->seed_register(device, reg, value) ? 1 : 0;
}

int contego_latched(const contego_checker* c, uint16_t device) {
  return c != nullptr && checker(c)->latched(device) ? 1 : 0;
}

uint32_t contego_worst_case_cost(const contego_checker* c) {
  return c != nullptr ? checker(c)->worst_case_cost() : 0;
}

uint32_t contego_task_period_us(const contego_checker* c, uint16_t task) {
  if (c == nullptr) return 0;
  const core::Checker* k = checker(c);
  return task < k->task_count() ? k->task(task).period_us : 0;
}

uint32_t contego_device_count(const contego_checker* c) {
  return c != nullptr ? checker(c)->device_count() : 0;
}

int contego_device_info_of(const contego_checker* c, uint16_t device, contego_device_info* out) {
  if (c == nullptr || out == nullptr || device >= checker(c)->device_count()) return 0;
  const core::DeviceRecord& d = checker(c)->device(device);
  __builtin_memset(out, 0, sizeof(*out));
  out->role = d.role;
  out->bus = d.bus;
  out->ten_bit = d.ten_bit;
  out->addr = d.addr;
  out->sample_request_len = d.sample_request_len <= sizeof(out->sample_request)
                                ? d.sample_request_len
                                : static_cast<uint8_t>(sizeof(out->sample_request));
  __builtin_memcpy(out->sample_request, d.sample_request, sizeof(out->sample_request));
  out->sample_len = d.sample_len;
  out->sample_period_us = d.sample_period_us;
  out->max_sample_age_us = d.max_sample_age_us;
  return 1;
}

uint32_t contego_task_actuates(const contego_checker* c, uint16_t task) {
  if (c == nullptr || task >= checker(c)->task_count()) return 0;
  return checker(c)->access(task).actuate_devices;
}

const char* contego_load_status_name(uint8_t status) {
  return core::load_status_name(static_cast<core::LoadStatus>(status));
}
const char* contego_reason_name(uint8_t reason) {
  return core::reason_name(static_cast<core::Reason>(reason));
}
const char* contego_decision_name(uint8_t decision) {
  return core::decision_name(static_cast<core::Decision>(decision));
}

}  // extern "C"
