// The policy image: the binary artefact the policy compiler emits and the
// trusted core loads. docs/image-format.md is the normative description; this
// header is its C++ rendering.
//
// Layout: ImageHeader, then `section_count` SectionEntry records, then the
// section payloads. All integers are little-endian, all records have fixed
// size with explicit padding (no implicit padding anywhere), every section
// payload starts on a 4-byte boundary. Ids are indexes into their section
// (task 3 is the fourth TaskRecord). 0xFFFF in a 16-bit reference means
// "none". Names (for humans) live in the NAMES section, which the core checks
// for bounds but never reads. A field typed by an enum (Profile, Op, ...) is
// its fixed underlying type in the layout and can hold any byte of the image:
// the verifier refuses a value the enum does not name.
#ifndef CONTEGO_CORE_IMAGE_H_
#define CONTEGO_CORE_IMAGE_H_

#include <stdint.h>

#include "contego/core/verdict.h"

namespace contego::core {

inline constexpr uint32_t kImageMagic = 0x49475443u;  // "CTGI" read as little-endian
inline constexpr uint16_t kImageVersionMajor = 2;
inline constexpr uint16_t kImageVersionMinor = 5;  // 1: HAS_LAST, per-channel rate limits;
                                                   // 2: LatchMode::kHoldSafeUnrepaired;
                                                   // 3: InvariantRecord::scope;
                                                   // 4: DeviceRecord::gated, gate_bit;
                                                   // 5: InvariantRecord::after_safe
inline constexpr uint16_t kNone = 0xFFFF;
inline constexpr uint8_t kSameIndex = 0xFF;  // TemplateRecord::index: the checked command's channel

struct ImageHeader {
  uint32_t magic;
  uint16_t version_major;  // a different major is refused
  uint16_t version_minor;  // newer minors are accepted (only additive changes)
  uint32_t total_size;     // bytes, header included
  uint32_t checksum;       // CRC-32 (IEEE, reflected, as zlib) of bytes [16, total_size)
  uint32_t section_count;
  uint32_t flags;        // must be 0 in version 2.0
  uint32_t reserved[2];  // must be 0
};
static_assert(sizeof(ImageHeader) == 32);

enum class SectionKind : uint32_t {
  kTasks = 1,          // TaskRecord[]
  kDevices = 2,        // DeviceRecord[]
  kAliases = 3,        // AliasRecord[]
  kCommands = 4,       // CommandRecord[]
  kFields = 5,         // FieldRecord[]
  kSignals = 6,        // SignalRecord[]
  kRates = 7,          // RateRecord[]
  kInvariants = 8,     // InvariantRecord[]
  kTemplates = 9,      // TemplateRecord[]
  kCode = 10,          // Insn[]
  kConstants = 11,     // int64_t[]
  kAccess = 12,        // AccessRecord[], one per task, same order
  kRegisterInit = 13,  // RegisterInitRecord[]: power-on values of register-map devices
  kNames = 0x100,      // NUL-terminated UTF-8 strings; `name` fields are offsets into it
};

struct SectionEntry {
  uint32_t kind;    // SectionKind
  uint32_t offset;  // from the start of the image, multiple of 4
  uint32_t size;    // bytes; must equal count * record size for record sections
  uint32_t count;   // records (bytes for kNames)
};
static_assert(sizeof(SectionEntry) == 16);

// --- tasks --------------------------------------------------------------
struct TaskRecord {
  uint32_t period_us;
  uint32_t deadline_us;
  uint32_t wcet_us;
  uint16_t priority;            // larger = more important (as SCHED_FIFO)
  uint16_t actuations_per_job;  // N_i of the paper's appendix
  uint32_t overhead_ns;         // C^o declared in the policy, 0 = unspecified
  uint32_t name;
};
static_assert(sizeof(TaskRecord) == 24);

// --- devices --------------------------------------------------------------
enum DeviceRole : uint8_t { kRoleActuator = 1, kRoleSensor = 2 };  // bit set

enum class Profile : uint8_t {
  kFrame = 1,        // fixed-length command frames [opcode, v1, v2, ...] (GoPiGo2, line follower)
  kRegisterMap = 2,  // [register, data...] writes into an 8-bit register space (PCA9685, generic)
};

enum class AutoIncrement : uint8_t {
  kNever = 0,   // every data byte of a write lands in the addressed register
  kAlways = 1,  // data bytes land in consecutive registers
  kBit = 2,  // as kAlways while bit `ai_bit` of shadow register `ai_reg` is set (PCA9685 MODE1.AI)
};

enum class LatchMode : uint8_t {
  kOff = 0,
  kHoldSafe = 1,  // after `latch_count` violations within `latch_window_us`: drive the safe
                  // state once, then ignore every actuation until reset_latch()
  // (since 2.2) as kHoldSafe, counting only the violations the policy could not
  // repair: an invariant's violation or fault whose verdict is not the
  // invariant's computed expected command (`else failsafe expected`). Refused
  // commands of other tasks, forbidden commands and expected substitutes do not
  // count: the device stays on the policy's line, and latching would hand the
  // attacker the stop.
  kHoldSafeUnrepaired = 2,
};

struct DeviceRecord {
  uint8_t role;  // DeviceRole bits
  Profile profile;
  uint8_t bus;      // i2c-N
  uint8_t ten_bit;  // 1 if `addr` is a 10-bit address
  uint16_t addr;
  uint16_t command_first;  // range in kCommands
  uint16_t command_count;
  // kFrame: a write is accepted when its length is frame_len, or frame_len +
  // prefix_len (the device acts on the last frame_len bytes). Other lengths
  // are malformed.
  uint8_t frame_len;
  uint8_t prefix_len;  // 0 or 1
  // kRegisterMap:
  AutoIncrement auto_increment;
  uint8_t ai_reg;
  uint8_t ai_bit;
  LatchMode latch_mode;
  uint8_t latch_count;         // K, 1..kMaxLatchCount when latch_mode != kOff
  uint8_t sample_request_len;  // sensors: bytes the host writes before reading a sample
  uint8_t sample_request[8];
  uint8_t sample_len;  // sensors: bytes read per sample (<= kMaxSampleBytes)
  // kFrame (since 2.1): 1 = a one-byte write [opcode] of a kQuery command is
  // that query (a register pointer such as the DI line follower's 0x12 "board
  // name"); 0 = one-byte writes are malformed.
  uint8_t short_queries;
  // kRegisterMap (since 2.4): command `command_first + gated - 1` takes
  // effect only while bit `gate_bit` of register `ai_reg` is set (PCA9685:
  // PRE_SCALE only while MODE1 SLEEP stops the oscillator); 0 = none.
  uint8_t gated;
  uint8_t gate_bit;
  // kRegisterMap (since 2.0): the bytes a commit of command
  // `command_first + broadcast` writes are also loaded into the same group
  // offsets of every channel of command `command_first + broadcast_target`, as
  // the device does (PCA9685: ALL_LED_* fill every LEDn register), so the
  // shadow follows. 0 / 0 = none (a command cannot broadcast onto itself).
  uint8_t broadcast;
  uint8_t broadcast_target;
  uint32_t latch_window_us;
  uint32_t sample_period_us;   // sensors: how often the host samples
  uint32_t max_sample_age_us;  // sensors: older samples make signals unavailable
  uint16_t safe_first;         // range in kTemplates: the safe state, applied in order
  uint16_t safe_count;
  uint32_t name;
};
static_assert(sizeof(DeviceRecord) == 52);

enum class AliasKind : uint8_t {
  kAddress = 0,  // writes to (bus, addr) are decoded as writes to `device`
  kGeneralCall =
      1,  // general call (addr 0): decoded as writes to `device` (one record per listener)
};

struct AliasRecord {
  uint8_t bus;
  AliasKind kind;
  uint16_t addr;
  uint16_t device;
  uint16_t pad;
};
static_assert(sizeof(AliasRecord) == 8);

// --- command decoding -------------------------------------------------------
enum class CommandClass : uint8_t {
  kActuate = 1,    // changes the physical world: access, rate and invariants apply
  kQuery = 2,      // asks a device for data (sensor request): needs read access only
  kForbidden = 3,  // never allowed (manufacturing tests, TestMode register ...)
};

struct CommandRecord {
  uint16_t device;
  CommandClass command_class;
  uint8_t field_count;   // <= kMaxFieldsPerCommand
  uint16_t field_first;  // range in kFields
  uint16_t group;        // substitution group; commands of one group can replace each other
  // kFrame: `match` is the opcode (frame byte 0). group_len/repeat/stride are 0.
  // kRegisterMap: the command covers registers
  //   match + i*stride + j  for i in [0, repeat), j in [0, group_len)
  // and `index` of a decoded command is i. The group commits (is checked and
  // written) when its last register (j = group_len-1) is written; writes of
  // earlier registers are staged.
  // kRegisterMap with group_len = repeat = stride = 0 (since 2.0): a
  // general-call command, the one-byte write [match] to the general-call
  // address (PCA9685 SWRST = 0x06). No fields; the device needs a kGeneralCall
  // alias. When one reaches the bus the device's shadow returns to its
  // power-on values (kRegisterInit).
  uint8_t match;
  uint8_t group_len;
  uint8_t repeat;
  uint8_t stride;
  uint32_t name;
};
static_assert(sizeof(CommandRecord) == 16);

enum FieldFlags : uint8_t { kFieldBigEndian = 1, kFieldSigned = 2 };

// A field is `nbytes` consecutive bytes starting at `offset` (frame byte
// offset, opcode = byte 0; or register offset within the group), assembled
// little- or big-endian, shifted right by `shift`, masked to `width` bits and
// optionally sign-extended from bit width-1.
struct FieldRecord {
  uint8_t offset;
  uint8_t nbytes;  // 1..4
  uint8_t shift;   // < 32
  uint8_t width;   // 1..32
  uint8_t flags;   // FieldFlags
  uint8_t pad[3];
  uint32_t name;
};
static_assert(sizeof(FieldRecord) == 12);

// --- state S(t) ---------------------------------------------------------------
enum class SignalKind : uint8_t {
  kRaw = 1,      // a field of the latest sample of sensor `device`
  kDerived = 2,  // the value a program returns (RET); may read only signals with a lower id
};

struct SignalRecord {
  SignalKind kind;
  uint8_t pad0;
  uint16_t device;    // kRaw: sensor device
  FieldRecord field;  // kRaw: where the value sits in the sample (field.name unused)
  int32_t valid_min;  // kRaw: values outside [valid_min, valid_max] are unavailable
  int32_t valid_max;
  uint16_t code_first;  // kDerived: program in kCode
  uint16_t code_len;
  uint32_t name;
};
static_assert(sizeof(SignalRecord) == 32);

// --- rules ---------------------------------------------------------------------
enum class Response : uint8_t {
  kIgnore = 1,    // drop; the actuator keeps its last command; the client is told success
  kFailsafe = 2,  // drop and write the template (or the program's computed command) instead
  kReject = 3,    // drop; the client's call fails with `reply_errno`
};

// Whose an invariant's state word (a sequence's position) is. kDevice: one
// word, kept across every task and session (the device's physical history).
// kTask: one word per task, kept across the task's sessions. kSession: one
// word per task, back at its initial value (0) whenever a session of the task
// ends (Checker::end_session), so a new run never inherits an old run's
// position.
enum class StateScope : uint8_t { kDevice = 0, kTask = 1, kSession = 2 };

// Commands are selected by a 128-bit mask over global command ids.
struct CommandMask {
  uint32_t bits[4];
};

struct RateRecord {
  uint16_t task;
  uint16_t device;
  uint16_t max_per_job;  // theta-hat: commands allowed in one job; the next ones get `response`
  // 0: commands of every channel count; n: only those of channel n-1 (a
  // repeated register group). Images before 2.1 had a u32 count here.
  uint8_t only_channel;
  uint8_t reserved;      // 0
  CommandMask commands;  // which commands count
  Response response;
  uint8_t reply_errno;
  uint16_t template_id;  // kFailsafe: substitute (kNone = ignore)
  uint32_t name;
};
static_assert(sizeof(RateRecord) == 32);

struct InvariantRecord {
  uint16_t device;      // the actuator it guards
  uint16_t code_first;  // program in kCode: ends in PASS, FAIL or FAIL_SUBST
  uint16_t code_len;
  Response response;  // on FAIL (FAIL_SUBST always means kFailsafe)
  uint8_t reply_errno;
  uint16_t template_id;  // kFailsafe on FAIL: substitute (kNone = ignore)
  StateScope scope;      // of its state word (since version 2.3; 0 before)
  // kDevice scope only (since 2.5; 0 before): when the device's safe state is
  // driven, the state word becomes after_safe - 1 (the position after the
  // value it writes); 0: unchanged.
  uint8_t after_safe;
  CommandMask commands;  // commands it applies to
  uint32_t name;
};
static_assert(sizeof(InvariantRecord) == 32);

// A constant command. `command` == kNone means "the command being checked",
// so a template can force one field (speed = 80) and keep the others.
// `index` is the register-map channel the command is written to: kSameIndex
// means the checked command's channel (channel 0 when the substitute command
// has no such channel); a safe state, written when no command is being
// checked, names its channel explicitly. Frame commands and kNone use kSameIndex.
struct TemplateRecord {
  uint16_t command;
  uint8_t set_mask;  // bit f: values[f] replaces field f; other fields keep their current value
  uint8_t index;     // channel (group index) of `command`, or kSameIndex (since version 2.0)
  int32_t values[8];
};
static_assert(sizeof(TemplateRecord) == 36);

struct AccessRecord {
  uint32_t actuate_devices;  // bit k: the task may send kActuate commands to device k
  uint32_t read_devices;     // bit k: the task may read device k and send it kQuery commands
};
static_assert(sizeof(AccessRecord) == 8);

struct RegisterInitRecord {
  uint16_t device;
  uint8_t reg;
  uint8_t value;
};
static_assert(sizeof(RegisterInitRecord) == 4);

// --- bytecode --------------------------------------------------------------------
// A stack machine over int64 values. Jumps are forward only, so a program of
// n instructions executes at most n of them: the cost bound is its length.
// Arithmetic is checked: overflow, division by zero and reading a missing
// field or an unavailable signal fault the program, and a fault is a
// violation (fail closed). Booleans are 0 and 1; any non-zero is true.
enum class Op : uint8_t {
  kNop = 0,
  kPush = 1,       // push imm
  kPushConst = 2,  // push constants[b]
  kSignal = 3,     // push signal b (fault if unavailable; derived signals may load only ids < own)
  kField = 4,      // push field slot b of the checked command (fault if it has no such field)
  kCommand = 5,    // push the checked command's global command id
  kIndex = 6,      // push the checked command's group index (register-map channel)
  kJobCount = 7,  // push how many commands of this task to this device this job (this one included)
  kLastField = 8,  // push field slot b of the last command of the same kind that reached the
                   // device (fault if none yet): rate-of-change and replay rules
  kSinceLast = 9,  // push microseconds since that command reached the device (fault if none)
  kState = 10,     // push this invariant's state word (starts at 0; sequences)
  kSetState = 11,  // pop into this invariant's pending state word; it is committed only if the
                   // transaction's final decision writes to the bus (allow or fail-safe)
  kHasLast = 12,   // push 1 if a command of the same kind (and channel) has reached the device,
                   // else 0: guards LAST_FIELD / SINCE_LAST for `last(x, default)`
  kAdd = 16,
  kSub,
  kMul,
  kDiv,
  kMod,
  kNeg,
  kAbs,
  kMin,
  kMax,
  kEq = 32,
  kNe,
  kLt,
  kLe,
  kGt,
  kGe,
  kAnd,
  kOr,
  kNot,
  kDup = 48,
  kDrop = 49,
  kJumpIfZero = 64,  // pop; if zero, pc += imm (imm >= 1, target <= program length - 1)
  kJump = 65,        // pc += imm (imm >= 1)
  kSubstBegin =
      80,  // start a substitute: command b (kNone = the checked command), fields = current values
  kSubstField = 81,  // pop into field slot b of the substitute
  kPass = 96,        // invariant holds
  kFail = 97,        // violated: use the invariant's static response
  kFailSubst = 98,   // violated: fail-safe with the substitute built by kSubstBegin/kSubstField
  kReturn = 99,      // derived signal: pop the value
};

struct Insn {
  Op op;
  uint8_t a;    // reserved, 0
  uint16_t b;   // small operand (index)
  int32_t imm;  // immediate or jump offset in instructions
};
static_assert(sizeof(Insn) == 8);

}  // namespace contego::core

#endif  // CONTEGO_CORE_IMAGE_H_
