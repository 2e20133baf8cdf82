// The checker's state and its implementation (the public Checker in
// contego/core/checker.h holds it in fixed, aligned storage and forwards to
// it): fixed-capacity tables copied from the image, and the runtime state
// (shadow registers, staging, rate windows, latches, history). Sized by
// limits.h; no pointers into the image, nothing allocated.
#ifndef CONTEGO_CORE_STATE_H_
#define CONTEGO_CORE_STATE_H_

#include <stddef.h>
#include <stdint.h>

#include "contego/core/checker.h"

namespace contego::core::internal {
struct Place {};  // tag of the placement new below (no <new> in the freestanding core)
}  // namespace contego::core::internal

inline void* operator new(size_t, void* where, contego::core::internal::Place) noexcept {
  return where;
}

namespace contego::core::internal {

// Superinstructions the loader writes over `PUSH imm; <compare>; JZ off`
// (interpreter.cc, fuse_programs): the compare of the value on top of the
// stack with imm, and the jump (b = off) when it is false; and over
// `SIGNAL s; PUSH imm; <compare>; JZ off` (the k*SignalJz: b = s, a = off)
// `COMMAND; PUSH imm; <compare>; JZ off` (the k*CommandJz: a = off) and
// `FIELD f; PUSH imm; <compare>; JZ off` (the k*FieldJz: b = f, a = off).
// Opcodes no image may carry (the verifier refuses everything above
// Op::kReturn).
enum class Fused : uint8_t {
  kEqJz = 0xE0,
  kNeJz,
  kLtJz,
  kLeJz,
  kGtJz,
  kGeJz,
  kEqSignalJz = 0xF0,  // the same order: kEqJz + 0x10
  kNeSignalJz,
  kLtSignalJz,
  kLeSignalJz,
  kGtSignalJz,
  kGeSignalJz,
  kEqCommandJz = 0xD0,  // COMMAND; PUSH imm; <compare>; JZ (a = off): kEqJz - 0x10
  kNeCommandJz,
  kLtCommandJz,
  kLeCommandJz,
  kGtCommandJz,
  kGeCommandJz,
  kEqFieldJz = 0xC0,  // FIELD f; PUSH imm; <compare>; JZ (b = f, a = off): kEqJz - 0x20
  kNeFieldJz,
  kLtFieldJz,
  kLeFieldJz,
  kGtFieldJz,
  kGeFieldJz,
};

// What evaluating a signal gave.
enum class SignalStatus : uint8_t { kOk, kUnavailable, kFault };

// How a program run ended: one of its terminators, or a fault (a missing
// signal told apart from any other).
enum class Exit : uint8_t { kPass, kFail, kFailSubst, kReturn, kUnavailable, kFault };

struct DeviceState {
  uint8_t shadow[kMaxRegisters];       // register-map: the values the device holds
  uint8_t staged[kMaxRegisters];       // register-map: written but not yet committed
  uint8_t staged_task[kMaxRegisters];  // which task staged each register
  uint32_t staged_bits[kMaxRegisters / 32];
  uint8_t lookup[kMaxRegisters];        // opcode / register -> offset in the device's commands
  uint8_t power_on[kMaxRegisters];      // register-map: values after reset (kRegisterInit)
  uint64_t violations[kMaxLatchCount];  // ring of the last violation times
  uint8_t violation_count;
  uint8_t violation_next;
  bool latched;
};
struct LastCommand {
  uint64_t time_us;
  int32_t fields[kMaxFieldsPerCommand];
  bool valid;
};
struct SignalMemo {
  uint32_t epoch;
  SignalStatus status;
  bool kept;  // derived: value/status stay valid while `inputs` is unchanged
  int64_t value;
  uint64_t inputs;  // derived: sum of its sensors' SampleMemo::generation when computed
};
struct SampleMemo {
  uint32_t epoch;
  uint32_t len;
  uint64_t taken_at_us;
  // Bumped whenever the sample's bytes, its length or its freshness change;
  // never decreases, so a sum over fixed sensors is unchanged only if each is.
  uint64_t generation;
  bool fresh;  // not older than the device's max_sample_age_us
  uint8_t bytes[kMaxSampleBytes];
};
struct TaskWindow {
  uint64_t key;       // job number (top bit set) or now / period
  uint64_t start_us;  // timed: key * period, where the window starts
  bool valid;
  bool timed;  // keyed by time (no job number, a period)
};
// What the checks made of one decoded command (kept for the audit and
// for combining the commands of one transaction).
struct Outcome {
  uint16_t device;
  uint16_t command;  // kNone: undecoded
  uint8_t index;
  uint8_t field_count;
  uint8_t base_reg;   // register map: first register of the group
  uint8_t group_len;  // register map: 0 for frames
  int32_t fields[kMaxFieldsPerCommand];
  Decision decision;
  Reason reason;
  RuleKind rule_kind;
  uint8_t reply_errno;
  uint16_t rule;
  uint16_t emit_offset;  // this command's emitted bytes inside the verdict
  uint16_t emit_len;
  uint8_t emit_index;    // its first write in the verdict
  uint16_t bus_command;  // the command whose fields reached the bus (kNone: none)
  uint8_t bus_index;     // and its channel (register-map group index)
  int32_t bus_fields[kMaxFieldsPerCommand];
};
// The command being checked: its bytes (frame after the prefix, or the
// register group) and decoded fields.
struct Decoded {
  uint16_t device;
  uint16_t command;
  uint8_t index;
  uint8_t prefix;  // frame: bytes before the frame (0 or 1)
  uint8_t prefix_byte;
  uint8_t base_reg;
  uint8_t field_count;
  uint32_t len;
  uint32_t written[kMaxRegisters / 32];  // register map: group offsets this commit writes
  int32_t fields[kMaxFieldsPerCommand];
  uint8_t bytes[kMaxRegisters];
};
struct Subst {
  bool active;
  uint16_t command;  // kNone: the checked command
  uint8_t index;     // channel, kSameIndex: the checked command's
  uint8_t set_mask;
  int32_t values[kMaxFieldsPerCommand];
};
// A substitute command, encoded (build_substitute): its bytes (the frame, or
// the register group), which command and channel, and its fields.
struct Encoded {
  uint8_t bytes[kMaxRegisters];
  uint32_t len;
  uint16_t command;
  uint8_t index;
  int32_t fields[kMaxFieldsPerCommand];
};
// A register's staging before a check changed it (its shadow is journaled
// apart, in ShadowUndo: only stores that change a value pay for that).
struct Undo {
  uint16_t device;
  uint8_t reg;
  uint8_t staged;
  uint8_t staged_task;
  bool staged_bit;
};
struct ShadowUndo {
  uint16_t device;
  uint8_t reg;
  uint8_t value;
};
struct TxContext {
  Verdict* out;
  uint32_t outcome_count;
  bool overflow;     // too many commands / undo entries: fail closed
  bool emit_failed;  // the verdict ran out of emit space
  uint16_t undo_device;
  uint16_t shadow_device;
  uint32_t undo_count;
  uint32_t shadow_count;
  uint32_t saved[kMaxRegisters / 32];
  uint32_t shadow_saved[kMaxRegisters / 32];
  uint32_t pending_state[kMaxInvariants / 32];
  uint16_t staged_command;  // first command whose group was only staged (kNone: none)
  uint8_t staged_index;
  bool any_pending;  // some bit of pending_state is set (in the padding before outcomes)
  Outcome outcomes[kMaxCommandsPerTransaction];
  Undo undo[kMaxRegisters];
  ShadowUndo shadow_undo[kMaxRegisters];
};
// What a transfer changed in the device model, to undo it on abort.
struct ModelCopy {
  uint8_t shadow[kMaxRegisters];
  uint8_t staged[kMaxRegisters];
  uint8_t staged_task[kMaxRegisters];
  uint32_t staged_bits[kMaxRegisters / 32];
  uint32_t dropped_bits[kMaxRegisters / 32];  // dropped for good by a check of the transfer
  uint16_t device;
};
// The model a transfer saves: shadow, staged, staged_task and staged_bits,
// laid out alike in DeviceState and ModelCopy (one copy each way).
inline constexpr size_t kModelBytes = 3 * kMaxRegisters + kMaxRegisters / 8;
static_assert(offsetof(DeviceState, staged_bits) + kMaxRegisters / 8 == kModelBytes &&
              offsetof(ModelCopy, staged_bits) + kMaxRegisters / 8 == kModelBytes);
struct HistoryCopy {
  uint16_t slot;
  LastCommand last;
};
struct Journal {
  bool active;
  uint32_t acted;          // checks audited as acting (allow / fail-safe)
  uint32_t saved_devices;  // bit d: devices[] holds device d's model
  uint32_t device_count;
  uint32_t history_count;
  uint32_t saved_state[kMaxInvariants / 32];
  uint16_t state_task;  // the task whose task-scoped words state_words holds
  ModelCopy devices[kMaxTransferDevices];
  HistoryCopy history[kMaxTransferHistory];
  int64_t state_words[kMaxInvariants];
  Transaction first;  // the first check's (bytes not kept): for the abort's audit record
};
struct Env {
  const Transaction* tx;
  const Decoded* d;
  uint16_t invariant;  // kNone for derived signals
  Subst* subst;
};

// What a program's SIGNAL operands can reach (verifier.cc, reach()).
struct Reach {
  uint64_t signals;  // derived signals, transitively
  uint32_t sensors;  // devices whose samples they read
};

// What the verifier's steps read from the image itself (not copied).
struct LoadInput {
  const uint8_t* image;
  SectionEntry init;  // the kRegisterInit section
};

// Decides `o` (an errno only for a reject).
void decide(Outcome& o, Decision d, Reason r, RuleKind kind, uint16_t rule, uint8_t err);
// An audit record of `tx` with no rule and no fields.
AuditRecord audit_record(const Transaction& tx, uint16_t device, uint16_t command,
                         Decision decision, Reason reason);
// The substitute a template describes.
Subst template_subst(const TemplateRecord& t);

// Everything a load resets (clear_tables(): one memset of this base of
// CheckerState): the tables' record counts, what the load derives from them,
// and the runtime state the checks accumulate. Plain data without member
// initializers (so no derived member lives in its tail padding); a Checker
// value-initialises it.
struct ResetOnLoad {
  bool loaded_;
  uint32_t worst_case_cost_;
  // clang-format off
  uint32_t task_count_, device_count_, alias_count_, command_count_, field_count_, signal_count_,
           rate_count_, invariant_count_, template_count_, code_count_, constant_count_;
  // clang-format on
  uint64_t signal_deps_[kMaxSignals];  // derived signals each signal needs (transitively)
  uint64_t derived_mask_;
  uint32_t signal_devices_[kMaxSignals];  // sensors each signal can read (transitively)
  // The rule index (rates.cc, index_rules), built at load: which rate limits
  // and invariants can apply to a command, so that a check costs the rules
  // of its task and command, not every rule of the policy. Bit r of
  // rates_of_[task][device]: rates_[r] counts that task's commands to that
  // device; bit r of task_rates_[task]: rates_[r] is the task's; bit i of
  // invariants_of_[command]: invariants_[i] guards that command (on its
  // device). Iterated in bit order, which is the table's: the first rule
  // still decides.
  static_assert(kMaxRateLimits <= 64 && kMaxInvariants % 64 == 0);
  static constexpr uint32_t kInvariantWords = kMaxInvariants / 64;
  uint64_t rates_of_[kMaxTasks][kMaxDevices];
  uint64_t task_rates_[kMaxTasks];
  uint64_t invariants_of_[kMaxCommandDefs][kInvariantWords];
  // Runtime state.
  uint32_t epoch_;
  uint64_t executed_;
  DeviceState state_[kMaxDevices];
  // LAST_FIELD / SINCE_LAST history, kept per (command, channel): command c's
  // channel i lives in last_[last_first_[c] + i] (frame commands have one).
  uint16_t last_first_[kMaxCommandDefs];
  LastCommand last_[kMaxHistorySlots];
  SignalMemo signal_memo_[kMaxSignals];
  SampleMemo sample_memo_[kMaxDevices];
  TaskWindow windows_[kMaxTasks];
  uint32_t job_count_[kMaxTasks][kMaxDevices];
  uint32_t rate_used_[kMaxRateLimits];
  int64_t state_words_[kMaxInvariants];                  // kDevice scope
  int64_t task_state_words_[kMaxTasks][kMaxInvariants];  // kTask and kSession scope
};

class CheckerState : public ResetOnLoad {
 public:
  // verifier.cc: load() verifies the image completely, then derives costs.
  LoadResult load(const uint8_t* image, uint32_t size);
  void clear_tables();
  LoadResult verify(const uint8_t* image, uint32_t size);
  // The steps of verify() after the section table, run in this order.
  LoadResult verify_devices(const LoadInput& in);
  LoadResult verify_aliases(const LoadInput& in);
  LoadResult verify_commands(const LoadInput& in);
  LoadResult verify_decoding(const LoadInput& in);
  LoadResult verify_templates(const LoadInput& in);
  LoadResult verify_signals(const LoadInput& in);
  LoadResult verify_rules(const LoadInput& in);
  LoadResult verify_access(const LoadInput& in);
  LoadResult verify_programs(const LoadInput& in);
  bool operand_ok(const Insn& in, bool derived, uint16_t self, uint16_t device) const;
  bool verify_program(uint32_t code_first, uint32_t code_len, bool derived, uint16_t self,
                      uint16_t device, LoadResult* result);
  Reach reach(uint32_t code_first, uint32_t code_len) const;
  void compute_costs();
  // interpreter.cc: after compute_costs, the superinstructions (Fused).
  void fuse_programs();
  // rates.cc: after verify, the rule index (rates_of_, task_rates_, invariants_of_).
  void index_rules();
  bool inside_every_program(uint32_t at, uint32_t len) const;

  // checker.cc: the check path, its combination of outcomes, latches.
  void check(const Transaction& tx, Verdict* out);
  uint32_t find_targets(const Transaction& tx, uint16_t* targets) const;
  bool reserved_address(const Transaction& tx, uint32_t target_count) const;
  bool resolve_general_call(const Transaction& tx, Verdict* out);
  void check_device(const Transaction& tx, uint16_t dev);
  void evaluate(const Transaction& tx, Outcome& o);
  void count_acting(const Transaction& tx, const Outcome& o, uint64_t rates_hit);
  // Whether rate rule `rr` selects the decoded command `d` of `tx`'s task.
  bool selects(const RateRecord& rr, const Transaction& tx, const Decoded& d) const;
  // Whether a rate rule that selects `d` is spent for this job (it decides `d`).
  bool rate_decides(const Transaction& tx, const Decoded& d) const;
  // A rate rule that refuses (reject) `d` now, or kNone.
  uint16_t refusing_rate(const Transaction& tx, const Decoded& d) const;
  void refuse(uint16_t dev, Reason reason, uint8_t err);
  void decide_read(Outcome& o, const Transaction& tx, uint16_t dev) const;
  void truncate_emits(uint32_t count, uint32_t bytes);
  void begin_tx(Verdict* out);
  void respond(Outcome& o, Response response, uint8_t err, uint16_t template_id, Reason reason,
               RuleKind kind, uint16_t rule);
  void finish(const Transaction& tx, Verdict* out);
  void settle_model(const Transaction& tx, Decision decision);
  void audit(const Transaction& tx, const Outcome& o);
  Outcome* new_outcome(uint16_t dev);
  bool emit(const uint8_t* bytes, uint32_t len);
  void update_window(const Transaction& tx);
  LastCommand& last(uint16_t command, uint8_t index);
  void undo_save(uint16_t dev, uint8_t reg);
  // Records that `command` wrote `value` to register `reg` of `dev` (undoable),
  // with the device's broadcast into other channels.
  void store_shadow(uint16_t dev, uint16_t command, uint8_t reg, uint8_t value);
  void rollback();
  bool record_violation(uint16_t dev, uint64_t now_us);
  void reset_latch(uint16_t device);
  bool latched(uint16_t device) const;
  bool register_map(uint16_t device) const;
  bool seed_register(uint16_t device, uint8_t reg, uint8_t value);
  uint32_t command_registers(uint16_t device, uint8_t* regs) const;
  bool safe_state(uint16_t device, Verdict* out, bool apply);
  bool emit_safe_state(uint16_t dev);

  // decode.cc: device profiles, decoding writes and encoding substitutes.
  void check_frame(const Transaction& tx, uint16_t dev);
  void check_short_query(const Transaction& tx, uint16_t dev);
  Outcome* check_as_is(const Transaction& tx, uint16_t dev);
  void check_register_map(const Transaction& tx, uint16_t dev);
  void check_general_call_command(const Transaction& tx, uint16_t dev);
  // Clears a staged byte for good: an aborted transfer does not bring back
  // what its checks dropped and audited (a refused commit, an abandoned group).
  void drop_staged(uint16_t dev, uint32_t reg);
  void mark_dropped(uint16_t dev, uint32_t reg);  // drop_staged's journal half
  void drop_stale_staging(const Transaction& tx, uint16_t dev, uint16_t cid, uint32_t base);
  void audit_staging_drop(const Transaction& tx, uint16_t dev, uint32_t reg, uint16_t victim,
                          Reason reason, uint32_t& last_group);
  bool never_acts(const Transaction& tx, uint16_t dev, uint16_t cid, uint32_t index) const;
  void commit_group(const Transaction& tx, uint16_t dev, uint16_t cid, uint32_t base,
                    uint32_t index, uint32_t j, uint8_t val);
  Decoded& decode_start(uint16_t dev, uint16_t cid, uint8_t index, uint32_t len);
  void decode_fields(Decoded& d);
  bool build_substitute(const Subst& subst, const Decoded* request, uint16_t dev, Encoded& e);
  bool emit_encoded(uint16_t dev, const Decoded* request, const Encoded& e);
  bool emit_substitute(const Subst& subst, Outcome& o);

  // interpreter.cc: how a program ended; *result holds a kReturn's value.
  Exit run(uint16_t code_first, uint16_t code_len, const Env& env, int64_t* result);
  bool context_value(const Insn& in, const Env& env, int64_t* value);
  bool subst_op(const Insn& in, const Env& env, int64_t value);
  SignalStatus signal(uint16_t id, uint64_t now_us, int64_t* value);
  SignalStatus signal_now(uint16_t id, int64_t* value);  // memo first, then signal()
  SignalStatus raw_signal(uint16_t id, uint64_t now_us, int64_t* value);
  SampleMemo& sample(uint16_t device, uint64_t now_us);  // sampled at most once per check()

  // transfer.cc: the journal that undoes an aborted transfer; the model.
  void begin_transfer();
  void commit_transfer();
  void abort_transfer(Decision decision);
  bool journal_device(uint16_t dev);  // false: no room (the check is refused)
  void journal_history(LastCommand& slot);
  void journal_state(uint32_t invariant, uint16_t task);
  // The state word of invariant `i` as task `task` sees it (its scope decides).
  int64_t& state_word(uint32_t i, uint16_t task);
  uint32_t end_session(uint16_t task);
  // carry.cc: reload in place (Checker::carry_from).
  bool carry_pairs_agree(const CheckerState& old, const Checker::CarryMap& map) const;
  uint32_t carry_devices(const CheckerState& old, const Checker::CarryMap& map);
  Checker::CarryResult carry_from(const CheckerState& old, const Checker::CarryMap& map);
  bool shadow(uint16_t device, uint8_t reg, uint8_t* value) const;
  uint32_t model_crc() const;

  Host host_{};
  // The tables copied from the image (their record counts are ResetOnLoad's).
  // clang-format off
  TaskRecord tasks_[kMaxTasks]{};                 DeviceRecord devices_[kMaxDevices]{};
  AliasRecord aliases_[kMaxAliases]{};            CommandRecord commands_[kMaxCommandDefs]{};
  FieldRecord fields_[kMaxFieldDefs]{};           SignalRecord signals_[kMaxSignals]{};
  RateRecord rates_[kMaxRateLimits]{};            InvariantRecord invariants_[kMaxInvariants]{};
  TemplateRecord templates_[kMaxTemplates]{};     Insn code_[kMaxCodeWords]{};
  int64_t constants_[kMaxConstants]{};            AccessRecord access_[kMaxTasks]{};
  // clang-format on
  // The scratch of one check().
  uint64_t now_us_ = 0;
  bool general_call_ = false;  // this check() is a general call (no pointer-write reads)
  bool latch_event_ = false;   // a device latched during this check()
  uint16_t latch_device_ = kNone;
  int64_t pending_state_[kMaxInvariants]{};
  Decoded decoded_{};  // scratch of check(): kept out of the caller's stack
  TxContext tx_{};
  Journal journal_{};
};

}  // namespace contego::core::internal

#endif  // CONTEGO_CORE_STATE_H_
