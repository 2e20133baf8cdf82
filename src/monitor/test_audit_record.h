// Audit records for the audit log's tests: a decision on `original` (and the
// `substitute` written instead, if any) sent to `addr` in job `job`.
#ifndef CONTEGO_MONITOR_TEST_AUDIT_RECORD_H_
#define CONTEGO_MONITOR_TEST_AUDIT_RECORD_H_

#include <cstdint>
#include <span>

#include "contego/core/verdict.h"

namespace contego::monitor::testing {

// The bytes stay the caller's: they must outlive the record.
inline core::AuditRecord decision_record(uint32_t job, core::Decision decision, uint16_t addr,
                                         std::span<const uint8_t> original,
                                         std::span<const uint8_t> substitute = {}) {
  core::AuditRecord r{};
  r.job = job;
  r.decision = decision;
  r.addr = addr;
  r.original = original.data();
  r.original_len = static_cast<uint16_t>(original.size());
  r.substitute = substitute.empty() ? nullptr : substitute.data();
  r.substitute_len = static_cast<uint16_t>(substitute.size());
  return r;
}

}  // namespace contego::monitor::testing

#endif  // CONTEGO_MONITOR_TEST_AUDIT_RECORD_H_
