// Stable, human-readable names of the core's enums (tools print them; audit
// logs store the numbers). Each table is indexed by the enum's value.
#include "contego/core/checker.h"

namespace contego::core {
namespace {

template <uint32_t N>
const char* lookup(const char* const (&names)[N], uint32_t value) {
  return value < N && names[value] != nullptr ? names[value] : "unknown";
}

// clang-format off
constexpr const char* kLoadStatusNames[] = {
    "ok", "too-small", "bad-magic", "bad-version", "size-mismatch", "bad-checksum", "bad-header",
    "section-bounds", "duplicate-section", "unknown-section", "missing-section", "record-size",
    "too-many", "bad-tag", "bad-reference", "bad-field", "bad-program", "jump-backward",
    "jump-out-of-range", "program-too-long", "stack-underflow", "stack-overflow",
    "stack-mismatch", "no-terminator", "bad-name",
};
// clang-format on
static_assert(sizeof(kLoadStatusNames) / sizeof(kLoadStatusNames[0]) ==
              static_cast<uint32_t>(LoadStatus::kBadName) + 1);

// clang-format off
constexpr const char* kReasonNames[] = {
    "allowed", "staged", "read-allowed", nullptr, nullptr, nullptr, nullptr, nullptr, nullptr,
    nullptr, "not-loaded", "unknown-task", "unknown-device", "malformed", "too-long",
    "unknown-command", "forbidden-command", "access-denied", "read-denied", "rate-exceeded",
    "invariant-violated", "signal-unavailable", "program-fault", "latched", "staging-conflict",
    "encode-failed", "general-call", "reserved-address", "transfer-dropped",
    "staged-incomplete", "not-taken",
};
// clang-format on
static_assert(sizeof(kReasonNames) / sizeof(kReasonNames[0]) ==
              static_cast<uint32_t>(Reason::kNotTaken) + 1);

constexpr const char* kDecisionNames[] = {"allow", "ignore", "failsafe", "reject"};
static_assert(static_cast<uint32_t>(Decision::kReject) == 3);

}  // namespace

const char* load_status_name(LoadStatus status) {
  return lookup(kLoadStatusNames, static_cast<uint32_t>(status));
}
const char* reason_name(Reason reason) {
  return lookup(kReasonNames, static_cast<uint32_t>(reason));
}
const char* decision_name(Decision decision) {
  return lookup(kDecisionNames, static_cast<uint32_t>(decision));
}

}  // namespace contego::core
