// Semantic analysis: resolves every name of an ast::File against the device
// profiles, types every expression (integers, durations in microseconds,
// booleans), folds constants, bounds every value by interval analysis, and
// applies the policy rules (access, rate, invariant consistency, ranges).
// The result is a CheckedPolicy that lowering turns into an image without
// further checks. Problems are diagnostics; check() never throws.
#ifndef CONTEGO_POLICY_CHECK_CHECK_H_
#define CONTEGO_POLICY_CHECK_CHECK_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "devices/profile.h"
#include "policy/diag/diag.h"
#include "policy/parse/ast.h"

namespace contego::policy {

enum class Type : uint8_t { kInt, kDuration, kBool, kError };
std::string_view type_phrase(Type type);  // "a plain number", "a duration", "a boolean"

// A typed, resolved expression. Durations are microseconds.
struct IExpr;
using IExprPtr = std::shared_ptr<const IExpr>;

enum class IOp : uint8_t {
  kConst,      // value
  kSignal,     // signal id `slot`
  kField,      // field slot `slot` of the checked command, times `scale`
  kLastField,  // field slot `slot` of the last command of this kind, times `scale`
  kSinceLast,  // microseconds since the last command of this kind
  kIndex,      // register-map channel of the checked command
  kJobCount,   // commands of this task to this device that acted in this job
  kNeg,
  kNot,
  kAbs,
  kAdd,
  kSub,
  kMul,
  kDiv,
  kMod,
  kMin,
  kMax,
  kEq,
  kNe,
  kLt,
  kLe,
  kGt,
  kGe,
  kAnd,
  kOr,
  kLastOr,  // kids[0] (a kLastField or kSinceLast) if the history exists, else kids[1]
};

struct IExpr {
  IOp op = IOp::kConst;
  Type type = Type::kInt;
  int64_t value = 0;
  uint16_t slot = 0;
  int64_t scale = 1;
  int64_t lo = INT64_MIN, hi = INT64_MAX;  // interval of possible values
  std::vector<IExprPtr> kids;
  Span span;
  bool is_const() const { return op == IOp::kConst; }
};

std::string to_string(const IExpr& e);  // canonical text (used to compare conditions)

// A command of a device, resolved: the profile's command index plus values.
struct FieldValue {
  uint8_t slot = 0;
  IExprPtr value;  // for expectations: may be null (any value)
  // Expectation forms: exact value (value), range [lo_value, hi_value], set.
  IExprPtr lo_value, hi_value;
  std::vector<IExprPtr> set;
};

struct CommandValue {
  uint16_t command = 0;          // index in the device's ProfileSpec::commands
  std::optional<int64_t> index;  // register-map channel, if given
  std::vector<FieldValue> fields;
  Span span;
  bool constant() const;
};

struct Device {
  std::string name;
  Span span;
  devices::ProfileSpec profile;
  uint8_t bus = 0;
  uint16_t addr = 0;
  uint8_t role = 0;
  uint32_t sample_period_us = 0;
  uint32_t max_age_us = 0;
  bool max_age_declared = false;  // else the default (check.cc, default_max_ages)
  std::vector<CommandValue> safe;
  uint8_t latch_count = 0;
  uint32_t latch_window_us = 0;
  bool latch_unrepaired = false;  // count only violations the policy could not repair
  bool commanded = false;         // some task may actuate it
};

struct Signal {
  std::string name;
  Span span;
  bool raw = false;
  uint16_t device = 0;        // raw
  uint16_t sample_field = 0;  // raw: index in the device's sample_fields
  IExprPtr value;             // derived
  Type type = Type::kInt;
  int64_t lo = INT64_MIN, hi = INT64_MAX;
  bool used = false;
  bool implicit = false;  // created for a `dev.value` reference
};

struct Task {
  std::string name;
  Span span;
  std::string exe;
  // Who may run it (checked by the monitor on hello; empty = anyone allowed
  // to connect): a user / group name or numeric id, a systemd unit, a cgroup.
  std::string user, group, unit, cgroup;
  uint32_t sessions = 1;  // live sessions the monitor accepts at once
  // The errno an ignored call of this task fails with (`ignore_errno`); 0:
  // the call succeeds, the paper's IGNORE. Enforced by the host, not the image.
  uint8_t ignore_errno = 0;
  uint32_t period_us = 0, deadline_us = 0, wcet_us = 0;
  std::optional<uint32_t> phase_us;  // declared release offset on the monitor's clock
  uint16_t priority = 0;
  uint16_t actuations = 1;
  bool actuations_given = false;
  uint32_t overhead_ns = 0;
  std::vector<bool> actuate;  // per device
  std::vector<bool> read;     // per device
};

enum class ResponseKind : uint8_t {
  kIgnore,
  kReject,
  kFailsafeTemplate,
  kFailsafeExpected,
  kFailsafeComputed
};

struct Response {
  ResponseKind kind = ResponseKind::kIgnore;
  uint8_t reply_errno = 0;
  std::optional<CommandValue> command;  // template / computed command; no command = the checked one
  std::string text;                     // as written, for summaries
};

struct RateLimit {
  std::string name;  // "task->device"
  uint16_t task = 0, device = 0;
  std::vector<uint16_t> commands;  // profile command indexes
  uint32_t count = 0;
  std::optional<int64_t> index;  // only this channel counts
  Response response;
  std::string text;
  Span span;
};

enum class InvariantForm : uint8_t { kExpect, kRequire, kSequence };

struct Invariant {
  std::string name;
  Span span;
  uint16_t device = 0;
  std::vector<uint16_t> commands;  // profile command indexes it applies to
  std::optional<int64_t> index;    // only this channel
  InvariantForm form = InvariantForm::kRequire;
  IExprPtr when;     // may be null
  IExprPtr require;  // kRequire
  std::vector<CommandValue> expect;
  uint8_t sequence_slot = 0;
  std::vector<int64_t> sequence;
  // Whose position a sequence keeps: by default each run of a task starts at
  // the first value (a program's protocol is its own, docs/policy-language.md).
  core::StateScope scope = core::StateScope::kSession;
  Response response;
  std::string text;  // readable form
};

struct CheckedPolicy {
  std::vector<Device> devices;
  std::vector<Signal> signals;
  std::vector<std::pair<std::string, uint16_t>> signal_aliases;  // name → raw signal
  std::vector<Task> tasks;
  std::vector<RateLimit> rates;
  std::vector<Invariant> invariants;
};

using ProfileLookup = std::function<const devices::ProfileSpec*(std::string_view)>;

CheckedPolicy check(const ast::File& file, const SourceBuffer& source, DiagnosticEmitter& diags,
                    const ProfileLookup& profiles);

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_CHECK_CHECK_H_
