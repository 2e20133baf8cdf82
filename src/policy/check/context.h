// The checker's shared state (Sema) and the helpers its parts use. The
// class is defined once here; its member functions live by concern:
//   context.cc   names, the run order, whole-policy checks
//   constant.cc  constants, durations, folding
//   expr.cc      expression resolution (names, members, calls, operators)
//   device.cc    devices, register maps, commands and selectors
//   task.cc      tasks, signals, access, responses
//   rule.cc      limits and invariants
// Internal to src/policy/check: nothing outside includes it.
#ifndef CONTEGO_POLICY_CHECK_CONTEXT_H_
#define CONTEGO_POLICY_CHECK_CONTEXT_H_

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "policy/check/check.h"

namespace contego::policy::check_internal {

__extension__ typedef __int128 i128;  // exact intermediate arithmetic

using ast::ExprKind;

constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
constexpr int64_t kMax = std::numeric_limits<int64_t>::max();

inline int64_t sat(i128 v) {
  if (v > kMax) return kMax;
  if (v < kMin) return kMin;
  return static_cast<int64_t>(v);
}

inline std::string join_names(const std::vector<std::string>& names) {
  if (names.empty()) return "(none)";
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (i) out += ", ";
    out += "`" + names[i] + "`";
  }
  return out;
}

inline int64_t time_unit_scale(const std::string& unit) {
  if (unit == "us") return 1;
  if (unit == "ms") return 1000;
  if (unit == "s") return 1000000;
  return 0;
}

class Sema {
 public:
  Sema(const ast::File& file, const SourceBuffer& source, DiagnosticEmitter& diags,
       const ProfileLookup& profiles)
      : file_(file), source_(source), diags_(diags), profiles_(profiles) {}
  CheckedPolicy run();

 private:
  enum class SymKind { kConst, kDevice, kSignal, kListSignal, kTask, kInvariant };
  struct Sym {
    SymKind kind;
    size_t index;
    Span span;
  };
  struct Const {
    std::string name;
    Span span;
    IExprPtr value;
    bool used = false;
  };
  // Context for resolving an expression.
  struct Ctx {
    std::string what;                // "the condition of `INV1`" (for messages)
    bool constant = false;           // must fold to a constant
    bool signals = true;             // may read signals
    const Device* device = nullptr;  // fields of the checked command
    const std::vector<uint16_t>* commands = nullptr;
    size_t signal_limit = SIZE_MAX;  // derived signals may read only earlier ones
    std::string rule;                // rule text for FieldNotShared
  };
  static std::string sym_phrase(SymKind k);
  bool declare(const std::string& name, SymKind kind, size_t index, Span span);
  const Sym* lookup(const std::string& name) const;
  // `name` (written at `at`) as a symbol of `kind`; reports an unknown name
  // or a symbol of another kind (`phrase`: what was expected, "a task") and
  // returns null.
  const Sym* lookup_as(const std::string& name, Span at, SymKind kind, const std::string& phrase);

  // --- constants and expressions -------------------------------------------
  static IExprPtr make_const(int64_t v, Type t, Span span);
  static IExprPtr error_expr(Span span);
  void declare_const(const ast::ConstDecl& c);
  // Evaluates a constant expression of the given type; reports problems.
  std::optional<int64_t> const_value(const ast::Expr& e, Type want, const std::string& what);
  uint32_t duration_us(const ast::Expr& e, const std::string& what);
  uint32_t duration_ns(const ast::Expr& e, const std::string& what);
  std::optional<int64_t> int_in(const ast::Expr& e, const std::string& what, int64_t lo,
                                int64_t hi);
  IExprPtr fold(IOp op, Type type, std::vector<IExprPtr> kids, Span span);
  bool numeric(Type t);
  IExprPtr resolve(const ast::Expr& e, const Ctx& c);
  std::string source_text(Span s) const;
  IExprPtr signal_ref(uint16_t id, Span span, const Ctx& c);
  // A field of the checked command: same slot and scale in every command of the rule.
  IExprPtr field_ref(const std::string& name, Span span, const Ctx& c, IOp op);
  bool has_index(const Ctx& c) const;
  IExprPtr resolve_name(const ast::Expr& e, const Ctx& c);
  // `dev.value` → raw signal ids (one, or several for a list such as `line.raw`).
  std::optional<std::vector<uint16_t>> resolve_member(const ast::Expr& e, const Ctx& c);
  uint16_t raw_signal(uint16_t dev, size_t field, Span span);
  std::optional<std::vector<uint16_t>> resolve_list_signal(const ast::Expr& e, const Ctx& c);
  std::optional<std::vector<int64_t>> const_list(const ast::Expr& e, const std::string& what);
  IExprPtr resolve_call(const ast::Expr& e, const Ctx& c);
  // `last(field [, default])` and `since_last([default])`: the history of this
  // command kind and channel. Without a default, reading it before the first
  // command reached the device faults (fails closed); with one, the default
  // is used instead (lowered behind HAS_LAST).
  template <typename Positional>
  IExprPtr resolve_history(const ast::Expr& e, const Ctx& c, Positional& positional);
  // Σ (raw_i − white_i)·100 / (black_i − white_i) · w_i, as the vendor
  // computes it in floating point: each term is taken kLineScale times larger
  // and the sum divided once (truncating), so the result is within 1 of the
  // vendor's value (a per-term truncation was off by up to Σ|w_i|, enough to
  // judge an honest command near the threshold against the wrong branch).
  static constexpr int64_t kLineScale = 1000;
  IExprPtr resolve_line_position(const ast::Expr& e, const Ctx& c);
  IExprPtr resolve_binary(const ast::Expr& e, const Ctx& c);
  IExprPtr resolve_in(const ast::Expr& e, const Ctx& c);

  // --- devices -------------------------------------------------------------
  void declare_device(const ast::DeviceDecl& d);
  bool build_regmap(const ast::DeviceDecl& d, devices::ProfileSpec& p);
  void range_bounds(const ast::Expr& r, int64_t& lo, int64_t& hi);
  void resolve_safe_state(const ast::DeviceDecl& d);

  // --- commands ------------------------------------------------------------
  enum class CallMode { kExpect, kTemplate, kComputed };
  void unknown_field(const std::string& name, Span span, const Device& dev, uint16_t cmd);
  std::optional<uint16_t> find_command(const Device& dev, const std::string& name) const;
  std::vector<std::string> command_names(const Device& dev) const;
  // Checks a value against a field's range (values in the field's unit).
  bool in_field_range(const IExprPtr& v, const devices::FieldSpec& f, const std::string& what);
  // Checks that a value's type fits a field (duration fields take durations).
  bool value_fits(const IExprPtr& v, const devices::FieldSpec& f);
  // `cmd(args)` on device `dev_id`. In kExpect mode arguments may be ranges,
  // sets or `_`; in kTemplate mode they must be constants; in kComputed mode
  // they may read signals and the checked command (`rule_cmds`).
  std::optional<CommandValue> command_value(const ast::Expr& call, uint16_t dev_id, CallMode mode,
                                            const std::vector<uint16_t>* rule_cmds,
                                            const std::string& what);
  // Resolves a selector's command list (names or groups) to actuation commands.
  std::optional<std::vector<uint16_t>> selector_commands(const ast::Selector& s, uint16_t dev_id);
  std::vector<uint16_t> all_actuation(const Device& dev) const;
  // Looks up a device by name for a rule; reports and returns nullopt if bad.
  std::optional<uint16_t> rule_device(const ast::Ident& id, const std::string& what,
                                      bool need_actuator);
  std::optional<uint16_t> rule_task(const ast::Ident& id);

  // --- tasks, signals, access ----------------------------------------------
  void declare_task(const ast::TaskDecl& d, uint32_t overhead_ns);
  void declare_signal(const ast::SignalDecl& d);
  void apply_allow(const ast::AllowDecl& a);

  // --- responses -----------------------------------------------------------
  std::optional<Response> response(const ast::Response& r, uint16_t dev_id,
                                   const std::vector<uint16_t>& cmds, bool in_invariant,
                                   bool has_expected, const std::string& rule);
  // The value of an errno name a policy may answer with (E0608 if unknown).
  std::optional<uint8_t> errno_named(const std::string& name, Span at);
  // A fail-safe never inherits an output override (full on / full off) from
  // the device's shadow: the ones it does not name are written as 0.
  void clear_unnamed_overrides(CommandValue& cv, const Device& dev,
                               const std::vector<uint16_t>& cmds);

  // --- rules -----------------------------------------------------------------
  void check_limit(const ast::LimitDecl& l);
  // The channel of a selection `dev.led(5)`: a repeated register group's
  // channel, within its repeat count.
  std::optional<int64_t> selected_channel(const ast::Expr& index, Span target,
                                          const std::vector<uint16_t>& cmds, const Device& device);
  IExprPtr condition(const ast::Expr& e, const Ctx& ctx);
  void check_invariant(const ast::InvariantDecl& d);
  // True if `e` reads the command history where no default guards it: before
  // the first command of its kind reached the device, it faults.
  static bool reads_unguarded_history(const IExpr* e);
  // A rule whose check faults until a command reached the device, and whose
  // response then writes nothing, refuses every command forever: the history
  // it waits for never starts. A constant or expected fail-safe writes a
  // command, so it is not reported.
  void warn_if_never_starts(const Invariant& inv, Span span);
  void default_max_ages();
  void final_checks();
  // Two expectations of one group can both hold: same command and no field
  // with two different constant values.
  static bool compatible(const CommandValue& a, const CommandValue& b);
  const ast::File& file_;
  const SourceBuffer& source_;
  DiagnosticEmitter& diags_;
  const ProfileLookup& profiles_;
  bool quiet_comparisons_ = false;  // W0704 is decided by the enclosing `in`
  CheckedPolicy out_;
  std::map<std::string, Sym> names_;
  std::vector<Const> consts_;
  std::vector<std::vector<uint16_t>> list_signals_;
  std::vector<Span> list_spans_;
  std::vector<bool> dev_ok_;
  std::set<size_t> bad_signals_;
  std::vector<std::pair<std::string, Span>> aliases_;  // `signal level = tank.level`
  std::set<std::string> used_aliases_;
  bool overhead_seen_ = false;
};

}  // namespace contego::policy::check_internal

#endif  // CONTEGO_POLICY_CHECK_CONTEXT_H_
