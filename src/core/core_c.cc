// The C ABI facade (include/contego/core_c.h) over Checker. The C structs
// mirror the C++ ones field for field; static_asserts keep them in step.
// Every entry point checks its pointers: a NULL checker or transaction
// fails closed, a NULL output is left alone.
#include "contego/core_c.h"

#include <stddef.h>

#include "contego/core/checker.h"

using contego::core::AuditRecord;
using contego::core::Checker;
using contego::core::Decision;
using contego::core::LoadStatus;
using contego::core::Reason;
using contego::core::Transaction;
using contego::core::Verdict;

// The C structs are the C++ ones, field for field: same offsets and sizes.
#define CONTEGO_SAME(C, CPP, field)                                         \
  static_assert(offsetof(C, field) == offsetof(CPP, field), #C "." #field); \
  static_assert(sizeof(C::field) == sizeof(CPP::field), #C "." #field)

static_assert(sizeof(contego_transaction) == sizeof(Transaction));
static_assert(alignof(contego_transaction) == alignof(Transaction));
CONTEGO_SAME(contego_transaction, Transaction, task);
CONTEGO_SAME(contego_transaction, Transaction, bus);
CONTEGO_SAME(contego_transaction, Transaction, kind);
CONTEGO_SAME(contego_transaction, Transaction, addr);
CONTEGO_SAME(contego_transaction, Transaction, ten_bit);
CONTEGO_SAME(contego_transaction, Transaction, pad);
CONTEGO_SAME(contego_transaction, Transaction, job);
CONTEGO_SAME(contego_transaction, Transaction, len);
CONTEGO_SAME(contego_transaction, Transaction, bytes);
CONTEGO_SAME(contego_transaction, Transaction, now_us);

static_assert(sizeof(contego_verdict) == sizeof(Verdict));
static_assert(alignof(contego_verdict) == alignof(Verdict));
CONTEGO_SAME(contego_verdict, Verdict, decision);
CONTEGO_SAME(contego_verdict, Verdict, reason);
CONTEGO_SAME(contego_verdict, Verdict, rule_kind);
CONTEGO_SAME(contego_verdict, Verdict, reply_errno);
CONTEGO_SAME(contego_verdict, Verdict, rule);
CONTEGO_SAME(contego_verdict, Verdict, device);
CONTEGO_SAME(contego_verdict, Verdict, addr);
CONTEGO_SAME(contego_verdict, Verdict, bus);
CONTEGO_SAME(contego_verdict, Verdict, emit_count);
CONTEGO_SAME(contego_verdict, Verdict, emit_bytes_used);
CONTEGO_SAME(contego_verdict, Verdict, emit_len);
CONTEGO_SAME(contego_verdict, Verdict, emit_bytes);

static_assert(sizeof(contego_audit_record) == sizeof(AuditRecord));
static_assert(alignof(contego_audit_record) == alignof(AuditRecord));
CONTEGO_SAME(contego_audit_record, AuditRecord, time_us);
CONTEGO_SAME(contego_audit_record, AuditRecord, job);
CONTEGO_SAME(contego_audit_record, AuditRecord, task);
CONTEGO_SAME(contego_audit_record, AuditRecord, device);
CONTEGO_SAME(contego_audit_record, AuditRecord, command);
CONTEGO_SAME(contego_audit_record, AuditRecord, rule);
CONTEGO_SAME(contego_audit_record, AuditRecord, rule_kind);
CONTEGO_SAME(contego_audit_record, AuditRecord, decision);
CONTEGO_SAME(contego_audit_record, AuditRecord, reason);
CONTEGO_SAME(contego_audit_record, AuditRecord, index);
CONTEGO_SAME(contego_audit_record, AuditRecord, fields);
CONTEGO_SAME(contego_audit_record, AuditRecord, field_count);
CONTEGO_SAME(contego_audit_record, AuditRecord, bus);
CONTEGO_SAME(contego_audit_record, AuditRecord, addr);
CONTEGO_SAME(contego_audit_record, AuditRecord, original_len);
CONTEGO_SAME(contego_audit_record, AuditRecord, substitute_len);
CONTEGO_SAME(contego_audit_record, AuditRecord, original);
CONTEGO_SAME(contego_audit_record, AuditRecord, substitute);

#undef CONTEGO_SAME

static_assert(CONTEGO_MAX_EMITS == contego::core::kMaxEmits);
static_assert(CONTEGO_MAX_EMIT_BYTES == contego::core::kMaxEmitBytes);
static_assert(CONTEGO_MAX_FIELDS == contego::core::kMaxFieldsPerCommand);
static_assert(CONTEGO_NONE == contego::core::kNone);
static_assert(CONTEGO_ALLOW == static_cast<int>(contego::core::Decision::kAllow) &&
              CONTEGO_IGNORE == static_cast<int>(contego::core::Decision::kIgnore) &&
              CONTEGO_FAILSAFE == static_cast<int>(contego::core::Decision::kFailsafe) &&
              CONTEGO_REJECT == static_cast<int>(contego::core::Decision::kReject));
static_assert(CONTEGO_TX_WRITE == static_cast<int>(contego::core::TxKind::kWrite) &&
              CONTEGO_TX_READ == static_cast<int>(contego::core::TxKind::kRead) &&
              CONTEGO_TX_QUICK == static_cast<int>(contego::core::TxKind::kQuick));

// Placement new without <new>: the freestanding core has no libstdc++ headers.
inline void* operator new(size_t, void* where, int /*tag*/) noexcept { return where; }

namespace {

constexpr uint8_t kEperm = 1;
constexpr uint8_t kEinval = 22;

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
  if (c == nullptr) return contego_load_result{static_cast<uint8_t>(LoadStatus::kTooSmall), 0, 0};
  const contego::core::LoadResult r = checker(c)->load(image, size);
  return contego_load_result{static_cast<uint8_t>(r.status), r.section, r.index};
}

void contego_set_host(contego_checker* c, const contego_host* host) {
  if (c == nullptr) return;
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
  if (out == nullptr) return;
  if (c == nullptr || tx == nullptr) {
    // Fail closed, as the checker does for a transaction it cannot decide.
    __builtin_memset(out, 0, sizeof(*out));
    out->decision = CONTEGO_REJECT;
    out->reason = static_cast<uint8_t>(c == nullptr ? Reason::kNotLoaded : Reason::kMalformed);
    out->reply_errno = c == nullptr ? kEperm : kEinval;
    out->rule = CONTEGO_NONE;
    out->device = CONTEGO_NONE;
    return;
  }
  checker(c)->check(*reinterpret_cast<const Transaction*>(tx), reinterpret_cast<Verdict*>(out));
}

int contego_safe_state(contego_checker* c, uint16_t device, contego_verdict* out) {
  if (c == nullptr || out == nullptr) return 0;
  return checker(c)->safe_state(device, reinterpret_cast<Verdict*>(out)) ? 1 : 0;
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
      static_cast<Decision>(decision <= CONTEGO_REJECT ? decision : uint8_t{CONTEGO_REJECT}));
}

uint8_t contego_combine_transfer(const contego_verdict* verdicts, uint32_t count,
                                 uint32_t* decider) {
  if (verdicts == nullptr && count != 0) {  // nothing to read: refuse the transfer
    if (decider != nullptr) *decider = 0;
    return static_cast<uint8_t>(contego::core::TransferAction::kRefuse);
  }
  const contego::core::TransferVerdict t =
      contego::core::combine_transfer(reinterpret_cast<const Verdict*>(verdicts), count);
  if (decider != nullptr) *decider = t.decider;
  return static_cast<uint8_t>(t.action);
}

void contego_reset_latch(contego_checker* c, uint16_t device) {
  if (c != nullptr) checker(c)->reset_latch(device);
}

int contego_latched(const contego_checker* c, uint16_t device) {
  return c != nullptr && checker(c)->latched(device) ? 1 : 0;
}

uint32_t contego_worst_case_cost(const contego_checker* c) {
  return c != nullptr ? checker(c)->worst_case_cost() : 0;
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
