// Lowering: a CheckedPolicy to an image::ImageModel (tables + bytecode).
// Every check was done before; what can still go wrong here is a limit of
// the image format (reported as diagnostics, e.g. too many commands).
//
// Invariant programs (all jumps forward, so cost = length):
//   prelude   [INDEX == channel] [when-condition]      → JZ pass
//   require   condition → JZ fail; PASS; fail: FAIL | computed FAIL_SUBST
//   expect    per expected command: COMMAND == id and every field matches → PASS,
//             else the expected command (FAIL_SUBST) or FAIL; then, for any other
//             command of an expected group: the group's expected command or FAIL
//   sequence  per position i: STATE == i → field == v_i → SET_STATE i+1; PASS
// Derived signals: the expression, then RETURN.
#ifndef CONTEGO_POLICY_LOWER_LOWER_H_
#define CONTEGO_POLICY_LOWER_LOWER_H_

#include <cstdint>
#include <vector>

#include "image/image_model.h"
#include "policy/check/check.h"
#include "policy/diag/diag.h"

namespace contego::policy {

struct LowerResult {
  bool ok = false;
  image::ImageModel model;
  uint32_t estimated_cost = 0;  // the compiler's own bound, before the verifier's
};

LowerResult lower(const CheckedPolicy& policy, DiagnosticEmitter& diags);

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_LOWER_LOWER_H_
