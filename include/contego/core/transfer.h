// A transfer: the transactions of one system call (the messages of an
// I2C_RDWR, the write and read of an SMBus process call) checked as one unit.
// The host calls Checker::begin_transfer(), check() for each transaction in
// order, then combine_transfer() over the verdicts, and commit_transfer() or
// abort_transfer() as the result says (docs/core.md, "Transfers").
#ifndef CONTEGO_CORE_TRANSFER_H_
#define CONTEGO_CORE_TRANSFER_H_

#include <stdint.h>

#include "contego/core/verdict.h"

namespace contego::core {

enum class TransferAction : uint8_t {
  kPerform = 0,     // every transaction allowed: commit, perform them all in order
  kRefuse = 1,      // one rejected: abort, nothing acts, the call fails with its errno
  kIgnore = 2,      // one ignored (none rejected): abort, nothing acts, the call succeeds
  kSubstitute = 3,  // a single transaction, fail-safe: commit, perform its substitute
  kSafeState = 4,   // several, one fail-safe (none rejected or ignored): abort, then drive
                    // the safe state of each fail-safe transaction's device; nothing else acts
};

struct TransferVerdict {
  TransferAction action;
  uint32_t decider;  // index of the verdict that decided (0 for kPerform)
};

// Reject over ignore over fail-safe over allow; `count` verdicts in message order.
inline TransferVerdict combine_transfer(const Verdict* verdicts, uint32_t count) {
  const Decision order[3] = {Decision::kReject, Decision::kIgnore, Decision::kFailsafe};
  const TransferAction action[3] = {TransferAction::kRefuse, TransferAction::kIgnore,
                                    TransferAction::kSafeState};
  for (uint32_t k = 0; k < 3; ++k) {
    for (uint32_t i = 0; i < count; ++i) {
      if (verdicts[i].decision != order[k]) continue;
      if (order[k] == Decision::kFailsafe && count == 1) return {TransferAction::kSubstitute, 0};
      return {action[k], i};
    }
  }
  for (uint32_t i = 0; i < count; ++i) {  // an unknown decision fails closed
    if (verdicts[i].decision != Decision::kAllow) return {TransferAction::kRefuse, i};
  }
  return {TransferAction::kPerform, 0};
}

// The decision an aborted transfer's audit record carries.
inline Decision transfer_decision(TransferAction action) {
  switch (action) {
    case TransferAction::kPerform:
      return Decision::kAllow;
    case TransferAction::kIgnore:
      return Decision::kIgnore;
    case TransferAction::kSubstitute:
    case TransferAction::kSafeState:
      return Decision::kFailsafe;
    case TransferAction::kRefuse:
      break;
  }
  return Decision::kReject;
}

}  // namespace contego::core

#endif  // CONTEGO_CORE_TRANSFER_H_
