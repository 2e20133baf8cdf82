// What the checker decides about one transaction, and the audit record it
// emits for each decoded command.
//
// The host performs exactly the writes listed in a Verdict and nothing else:
// for an allowed frame write that is a copy of the checked bytes; for a
// register-map commit it is the staged registers; for FAIL-SAFE it is the
// substitute. So the bytes that reach the bus are always bytes the core
// produced from its own copy ("never check one copy and act on another").
#ifndef CONTEGO_CORE_VERDICT_H_
#define CONTEGO_CORE_VERDICT_H_

#include <stdint.h>

#include "contego/core/limits.h"

namespace contego::core {

enum class Decision : uint8_t {
  kAllow = 0,     // perform `emits` (may be none: a staged register write)
  kIgnore = 1,    // perform nothing; tell the client it succeeded (paper's IGNORE)
  kFailsafe = 2,  // perform `emits` (the substitute) instead of the request
  kReject = 3,    // perform nothing; fail the client's call with `reply_errno`
};

// Why. Stable numbers: they appear in audit logs.
enum class Reason : uint8_t {
  kAllowed = 0,
  kStaged = 1,  // register-map write held until its group's last register arrives
  kReadAllowed = 2,
  kNotLoaded = 10,  // no verified image
  kUnknownTask = 11,
  kUnknownDevice = 12,     // no device at (bus, addr)
  kMalformed = 13,         // bytes do not form a command of the device's profile
  kTooLong = 14,           // more than kMaxWriteBytes
  kUnknownCommand = 15,    // opcode / register not in the profile
  kForbiddenCommand = 16,  // CommandClass::kForbidden
  kAccessDenied = 17,      // access matrix bit is 0
  kReadDenied = 18,
  kRateExceeded = 19,       // INV^RC
  kInvariantViolated = 20,  // a state invariant's program returned FAIL / FAIL_SUBST
  kSignalUnavailable = 21,  // an invariant needed a sensor signal that is missing or stale
  kProgramFault = 22,       // overflow, division by zero, missing field: fail closed
  kLatched = 23,            // device held in its safe state until an operator reset
  kStagingConflict = 24,    // another task had staged registers of this group; theirs dropped
  kEncodeFailed = 25,       // a substitute could not be encoded (value out of field range)
  kGeneralCall = 26,        // a general call (address 0) that is no declared general-call command
  kReservedAddress = 27,    // a 7-bit address the I2C specification reserves (0x01-0x07, 0x78-0x7F)
  kTransferDropped = 28,    // checks of a transfer that did not act: another message refused it
  kStagedIncomplete = 29,   // a task's staged write its group never took (left, rewritten); dropped
  kNotTaken = 30,           // the device would not take it now (DeviceRecord::gated): not sent
};

// Records that follow another check instead of answering a request of their
// own: their bytes are another request's (a tool that reads a log as
// requests skips them).
constexpr bool is_follow_up(Reason r) {
  return r == Reason::kTransferDropped || r == Reason::kStagingConflict ||
         r == Reason::kStagedIncomplete;
}

enum class RuleKind : uint8_t { kNoRule = 0, kAccess = 1, kRate = 2, kInvariant = 3, kLatch = 4 };

struct Verdict {
  Decision decision;
  Reason reason;
  RuleKind rule_kind;
  uint8_t reply_errno;  // kReject: errno for the client; 0 otherwise
  uint16_t rule;        // index of the rate / invariant record; device id for kLatch
  uint16_t device;      // device the transaction was decoded for (kNone if unknown)
  uint16_t addr;        // address the emits go to
  uint8_t bus;
  uint8_t emit_count;  // writes to perform, in order
  uint16_t emit_bytes_used;
  uint16_t emit_len[kMaxEmits];
  uint8_t emit_bytes[kMaxEmitBytes];  // the writes, back to back
};

// One per decoded command (a transaction to a register map may carry several),
// and one for a transaction that could not be decoded. Pointers are valid only
// during the audit callback.
struct AuditRecord {
  uint64_t time_us;
  uint32_t job;
  uint16_t task;
  uint16_t device;   // kNone if no device matched
  uint16_t command;  // global command id, kNone if undecoded
  uint16_t rule;
  RuleKind rule_kind;
  Decision decision;
  Reason reason;
  uint8_t index;                         // register-map group index (channel)
  int32_t fields[kMaxFieldsPerCommand];  // decoded field values of the command
  uint8_t field_count;
  uint8_t bus;
  uint16_t addr;
  uint16_t original_len;
  uint16_t substitute_len;
  const uint8_t* original;    // the transaction's bytes
  const uint8_t* substitute;  // emitted bytes for kFailsafe (may be null)
};

}  // namespace contego::core

#endif  // CONTEGO_CORE_VERDICT_H_
