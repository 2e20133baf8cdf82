// The C ABI facade (include/contego/core_c.h) over Checker. The C structs
// mirror the C++ ones field for field; static_asserts keep them in step.
#include "contego/core_c.h"

#include <stddef.h>

#include "contego/core/checker.h"

using contego::core::AuditRecord;
using contego::core::Checker;
using contego::core::Transaction;
using contego::core::Verdict;

static_assert(sizeof(contego_transaction) == sizeof(Transaction));
static_assert(offsetof(contego_transaction, bytes) == offsetof(Transaction, bytes));
static_assert(offsetof(contego_transaction, now_us) == offsetof(Transaction, now_us));
static_assert(sizeof(contego_verdict) == sizeof(Verdict));
static_assert(offsetof(contego_verdict, emit_len) == offsetof(Verdict, emit_len));
static_assert(offsetof(contego_verdict, emit_bytes) == offsetof(Verdict, emit_bytes));
static_assert(sizeof(contego_audit_record) == sizeof(AuditRecord));
static_assert(offsetof(contego_audit_record, fields) == offsetof(AuditRecord, fields));
static_assert(offsetof(contego_audit_record, substitute) == offsetof(AuditRecord, substitute));
static_assert(CONTEGO_MAX_EMITS == contego::core::kMaxEmits);
static_assert(CONTEGO_MAX_EMIT_BYTES == contego::core::kMaxEmitBytes);

// Placement new without <new>: the freestanding core has no libstdc++ headers.
inline void* operator new(size_t, void* where, int /*tag*/) noexcept { return where; }

namespace {

// The caller's storage holds the checker and the C host it installed; the
// core's Host points at small trampolines that hand the C callbacks C types.
struct Facade {
  Checker checker;
  contego_host host;
};

Checker* checker(contego_checker* c) { return &reinterpret_cast<Facade*>(c)->checker; }
const Checker* checker(const contego_checker* c) {
  return &reinterpret_cast<const Facade*>(c)->checker;
}

uint32_t read_sample_trampoline(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                                uint64_t* taken_at_us) {
  const contego_host* h = static_cast<const contego_host*>(context);
  return h->read_sample(h->context, device, buf, capacity, taken_at_us);
}

void audit_trampoline(void* context, const AuditRecord* record) {
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
  const contego::core::LoadResult r = checker(c)->load(image, size);
  return contego_load_result{static_cast<uint8_t>(r.status), r.section, r.index};
}

void contego_set_host(contego_checker* c, const contego_host* host) {
  Facade* f = reinterpret_cast<Facade*>(c);
  contego::core::Host h{};
  if (host != nullptr) {
    f->host = *host;
    h.context = &f->host;
    h.read_sample = host->read_sample != nullptr ? read_sample_trampoline : nullptr;
    h.audit = host->audit != nullptr ? audit_trampoline : nullptr;
  }
  f->checker.set_host(h);
}

void contego_check(contego_checker* c, const contego_transaction* tx, contego_verdict* out) {
  checker(c)->check(*reinterpret_cast<const Transaction*>(tx), reinterpret_cast<Verdict*>(out));
}

int contego_safe_state(contego_checker* c, uint16_t device, contego_verdict* out) {
  return checker(c)->safe_state(device, reinterpret_cast<Verdict*>(out)) ? 1 : 0;
}

void contego_begin_transfer(contego_checker* c) { checker(c)->begin_transfer(); }
void contego_commit_transfer(contego_checker* c) { checker(c)->commit_transfer(); }
void contego_abort_transfer(contego_checker* c, uint8_t decision) {
  checker(c)->abort_transfer(static_cast<contego::core::Decision>(decision));
}

uint8_t contego_combine_transfer(const contego_verdict* verdicts, uint32_t count,
                                 uint32_t* decider) {
  const contego::core::TransferVerdict t =
      contego::core::combine_transfer(reinterpret_cast<const Verdict*>(verdicts), count);
  if (decider != nullptr) *decider = t.decider;
  return static_cast<uint8_t>(t.action);
}

void contego_reset_latch(contego_checker* c, uint16_t device) { checker(c)->reset_latch(device); }

int contego_latched(const contego_checker* c, uint16_t device) {
  return checker(c)->latched(device) ? 1 : 0;
}

uint32_t contego_worst_case_cost(const contego_checker* c) { return checker(c)->worst_case_cost(); }

uint32_t contego_task_period_us(const contego_checker* c, uint16_t task) {
  const Checker* k = checker(c);
  return task < k->task_count() ? k->task(task).period_us : 0;
}

const char* contego_load_status_name(uint8_t status) {
  return contego::core::load_status_name(static_cast<contego::core::LoadStatus>(status));
}
const char* contego_reason_name(uint8_t reason) {
  return contego::core::reason_name(static_cast<contego::core::Reason>(reason));
}
const char* contego_decision_name(uint8_t decision) {
  return contego::core::decision_name(static_cast<contego::core::Decision>(decision));
}

}  // extern "C"
