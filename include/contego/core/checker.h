// The trusted checker: loads a verified policy image and decides, for each bus
// transaction, allow / ignore / fail-safe / reject.
//
// Freestanding: no heap, no exceptions, no RTTI, no floating point, no OS
// calls; all state lives inside the Checker object (sizeof is fixed by
// limits.h, its layout private to src/core), so a host can place it in
// static storage or secure memory.
// Thread-safety: none. One Checker serves one request at a time, as the
// paper's secure-world checker does; hosts serialise calls.
// Cost: check() is bounded by the image's worst-case cost, reported by
// worst_case_cost() (bytecode instructions, forward jumps only).
#ifndef CONTEGO_CORE_CHECKER_H_
#define CONTEGO_CORE_CHECKER_H_

#include <stdint.h>

#include "contego/core/host.h"
#include "contego/core/image.h"
#include "contego/core/limits.h"
#include "contego/core/transaction.h"
#include "contego/core/transfer.h"
#include "contego/core/verdict.h"

namespace contego::core {

namespace internal {
class CheckerState;  // src/core/state.h
}  // namespace internal

// Bytes and alignment of the checker's state (src/core/state.h asserts them).
inline constexpr uint32_t kCheckerStateBytes = 256912;
inline constexpr uint32_t kCheckerStateAlign = 8;

// Why the verifier refused an image. Stable numbers (they appear in tools' output).
enum class LoadStatus : uint8_t {
  kOk = 0,
  kTooSmall = 1,
  kBadMagic = 2,
  kBadVersion = 3,
  kSizeMismatch = 4,  // header.total_size != buffer size
  kBadChecksum = 5,
  kBadHeader = 6,      // non-zero flags / reserved
  kSectionBounds = 7,  // section outside the image, misaligned, or overlapping another
  kDuplicateSection = 8,
  kUnknownSection = 9,
  kMissingSection = 10,
  kRecordSize = 11,    // size != count * record size
  kTooMany = 12,       // a count exceeds limits.h
  kBadTag = 13,        // an enum field holds an unknown value, or padding is non-zero
  kBadReference = 14,  // an id points outside its table or to the wrong kind of thing
  kBadField = 15,      // field geometry outside the frame / group / sample
  kBadProgram = 16,    // unknown opcode or operand
  kJumpBackward = 17,
  kJumpOutOfRange = 18,
  kProgramTooLong = 19,
  kStackUnderflow = 20,
  kStackOverflow = 21,
  kStackMismatch = 22,  // two paths reach an instruction with different stack depths
  kNoTerminator = 23,   // a path runs off the end of the program
  kBadName = 24,        // name offset outside kNames or not NUL-terminated
};

// Where the verifier stopped: which section and which record in it.
struct LoadResult {
  LoadStatus status;
  uint32_t section;  // SectionKind, 0 for the header
  uint32_t index;    // record index in that section (instruction index for kCode)
};

const char* load_status_name(LoadStatus status);  // "bad-checksum" ... (static strings)
const char* reason_name(Reason reason);           // "rate-exceeded" ...
const char* decision_name(Decision decision);     // "allow" / "ignore" / "failsafe" / "reject"

class Checker {
 public:
  Checker();
  Checker(const Checker&) = delete;
  Checker& operator=(const Checker&) = delete;

  // Verifies `image` completely, then copies it into this object's tables.
  // On failure the previously loaded policy is discarded and every check()
  // answers kReject/kNotLoaded (fail closed). The buffer is not kept.
  [[nodiscard]] LoadResult load(const uint8_t* image, uint32_t size);
  bool loaded() const;

  void set_host(const Host& host);

  // Decides about one transaction and fills `out`. Never fails: every error
  // path yields a fail-closed verdict with its reason.
  void check(const Transaction& tx, Verdict* out);

  // Writes the safe state of `device` (its templates, encoded) into `out` as
  // a kFailsafe verdict. Returns false if the device has none / is unknown.
  // `apply` false: only what it would write, the model left as it was (a
  // reload checks the new policy's safe states have a form, driving none).
  bool safe_state(uint16_t device, Verdict* out, bool apply = true);

  // Operator reset of a latched device.
  void reset_latch(uint16_t device);
  // A session (one run of a program bound to `task`) ended: the task's
  // session-scoped state words (StateScope::kSession) go back to their
  // initial value, so the task's next run starts its sequences afresh. The
  // register writes the task staged and never completed (a group whose last
  // register never came) are dropped: they never reached the device, and the
  // next run must not complete them. Returns how many were dropped, for the
  // host to report. Hosts call it where they drive the task's safe state on
  // exit.
  uint32_t end_session(uint16_t task);
  bool latched(uint16_t device) const;

  // Seeds the shadow copy of a register-map device (e.g. read back from the
  // hardware at start). Returns false for a bad device or a non-register-map profile.
  bool seed_register(uint16_t device, uint8_t reg, uint8_t value);
  // The registers the policy's commands of register-map device `device`
  // address (every register of every group), ascending, into `regs`
  // (kMaxRegisters entries): what a host reads back to seed the shadow.
  // Returns how many; 0 for a bad device or a non-register-map profile.
  uint32_t command_registers(uint16_t device, uint8_t* regs) const;

  // Transfers (contego/core/transfer.h): the check() calls between
  // begin_transfer() and commit_transfer() / abort_transfer() form one unit.
  // Each check() sees the model its predecessors left; abort_transfer()
  // restores the device model (register shadows and staging, state words,
  // "last command" history) to what it was at begin_transfer(). Rate counters,
  // job counts and latch violations count attempts and are kept. A transfer
  // changing more than kMaxTransferDevices devices or kMaxTransferHistory
  // history slots is refused (reject `too-long`) at the check that would.
  void begin_transfer();
  void commit_transfer();
  // Audits one `transfer-dropped` record with `decision` when a check of the
  // transfer had been audited as acting (allow / fail-safe).
  void abort_transfer(Decision decision);
  bool in_transfer() const;

  // The device model, for hosts comparing it with a read-back and for tests:
  // a register's shadow (false for a bad device or a non-register-map one),
  // and a CRC-32 over every shadow, staging, state word and history slot.
  bool shadow(uint16_t device, uint8_t reg, uint8_t* value) const;
  uint32_t model_crc() const;

  // Reload in place: takes over the run-time model of `old`, the checker this
  // freshly loaded one replaces, for the records `map` pairs (the host pairs
  // them by name). A paired device keeps its register shadows, staged writes
  // (of paired tasks), violations and latch; a paired task its job window and
  // per-device job counts; a paired rate limit its count in the current job;
  // a paired invariant its state words; a paired command its history. The
  // rest starts as after load(). Refused (nothing taken) when either checker
  // is in a transfer or not loaded, or a pair disagrees: an id out of range,
  // devices of another bus, address or profile, commands of unpaired devices
  // or other field counts, rate limits or invariants of other tasks, devices
  // or scope.
  struct CarryMap {
    // One entry per record of this checker's image, in its order: the old
    // image's id of the same record, or kNone.
    const uint16_t* tasks = nullptr;
    const uint16_t* devices = nullptr;
    const uint16_t* commands = nullptr;
    const uint16_t* rates = nullptr;
    const uint16_t* invariants = nullptr;
  };
  struct CarryResult {
    bool ok;
    uint32_t staged_dropped;  // staged register writes of tasks not paired
  };
  CarryResult carry_from(const Checker& old, const CarryMap& map);
  // How many records of each kind the loaded image has: the length of each
  // array of a CarryMap for this checker.
  struct RecordCounts {
    uint32_t tasks, devices, commands, rates, invariants;
  };
  RecordCounts record_counts() const;

  // Upper bound of bytecode instructions executed by one check() of a
  // single command, over all commands of the image (computed at load).
  uint32_t worst_case_cost() const;

  // Bytecode instructions executed by all check() calls since load()
  // (benchmarks report instructions per check with it).
  uint64_t executed_instructions() const;

  // Read access to the loaded tables (for hosts, tools and tests).
  uint32_t task_count() const;
  uint32_t device_count() const;
  const TaskRecord& task(uint16_t id) const;
  const DeviceRecord& device(uint16_t id) const;
  const AccessRecord& access(uint16_t task) const;  // the access matrix's row of `task`

 private:
  // The checker's tables and runtime state, defined in src/core (state.h):
  // fixed-size storage here so that a host can still place a Checker in
  // static storage or secure memory without knowing its layout. src/core
  // asserts that the state fits.
  internal::CheckerState& state() { return *reinterpret_cast<internal::CheckerState*>(storage_); }
  const internal::CheckerState& state() const {
    return *reinterpret_cast<const internal::CheckerState*>(storage_);
  }

  alignas(kCheckerStateAlign) unsigned char storage_[kCheckerStateBytes];
};

}  // namespace contego::core

#endif  // CONTEGO_CORE_CHECKER_H_
