// Stable, human-readable names of the core's enums (tools print them; audit
// logs store the numbers).
#include "contego/core/checker.h"

namespace contego::core {

const char* load_status_name(LoadStatus status) {
  switch (status) {
    case LoadStatus::kOk:
      return "ok";
    case LoadStatus::kTooSmall:
      return "too-small";
    case LoadStatus::kBadMagic:
      return "bad-magic";
    case LoadStatus::kBadVersion:
      return "bad-version";
    case LoadStatus::kSizeMismatch:
      return "size-mismatch";
    case LoadStatus::kBadChecksum:
      return "bad-checksum";
    case LoadStatus::kBadHeader:
      return "bad-header";
    case LoadStatus::kSectionBounds:
      return "section-bounds";
    case LoadStatus::kDuplicateSection:
      return "duplicate-section";
    case LoadStatus::kUnknownSection:
      return "unknown-section";
    case LoadStatus::kMissingSection:
      return "missing-section";
    case LoadStatus::kRecordSize:
      return "record-size";
    case LoadStatus::kTooMany:
      return "too-many";
    case LoadStatus::kBadTag:
      return "bad-tag";
    case LoadStatus::kBadReference:
      return "bad-reference";
    case LoadStatus::kBadField:
      return "bad-field";
    case LoadStatus::kBadProgram:
      return "bad-program";
    case LoadStatus::kJumpBackward:
      return "jump-backward";
    case LoadStatus::kJumpOutOfRange:
      return "jump-out-of-range";
    case LoadStatus::kProgramTooLong:
      return "program-too-long";
    case LoadStatus::kStackUnderflow:
      return "stack-underflow";
    case LoadStatus::kStackOverflow:
      return "stack-overflow";
    case LoadStatus::kStackMismatch:
      return "stack-mismatch";
    case LoadStatus::kNoTerminator:
      return "no-terminator";
    case LoadStatus::kBadName:
      return "bad-name";
  }
  return "unknown";
}

const char* reason_name(Reason reason) {
  switch (reason) {
    case Reason::kAllowed:
      return "allowed";
    case Reason::kStaged:
      return "staged";
    case Reason::kReadAllowed:
      return "read-allowed";
    case Reason::kNotLoaded:
      return "not-loaded";
    case Reason::kUnknownTask:
      return "unknown-task";
    case Reason::kUnknownDevice:
      return "unknown-device";
    case Reason::kMalformed:
      return "malformed";
    case Reason::kTooLong:
      return "too-long";
    case Reason::kUnknownCommand:
      return "unknown-command";
    case Reason::kForbiddenCommand:
      return "forbidden-command";
    case Reason::kAccessDenied:
      return "access-denied";
    case Reason::kReadDenied:
      return "read-denied";
    case Reason::kRateExceeded:
      return "rate-exceeded";
    case Reason::kInvariantViolated:
      return "invariant-violated";
    case Reason::kSignalUnavailable:
      return "signal-unavailable";
    case Reason::kProgramFault:
      return "program-fault";
    case Reason::kLatched:
      return "latched";
    case Reason::kStagingConflict:
      return "staging-conflict";
    case Reason::kEncodeFailed:
      return "encode-failed";
    case Reason::kGeneralCall:
      return "general-call";
    case Reason::kReservedAddress:
      return "reserved-address";
    case Reason::kTransferDropped:
      return "transfer-dropped";
  }
  return "unknown";
}

const char* decision_name(Decision decision) {
  switch (decision) {
    case Decision::kAllow:
      return "allow";
    case Decision::kIgnore:
      return "ignore";
    case Decision::kFailsafe:
      return "failsafe";
    case Decision::kReject:
      return "reject";
  }
  return "unknown";
}

}  // namespace contego::core
