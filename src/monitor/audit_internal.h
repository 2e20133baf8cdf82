// What the audit log's source files share (audit_log.cc: records and the
// chain; audit_file.cc: the file, its mapping and growth; audit_verify.cc:
// the verifier). Internal to contego_monitor.
#ifndef CONTEGO_MONITOR_AUDIT_INTERNAL_H_
#define CONTEGO_MONITOR_AUDIT_INTERNAL_H_

#include <cstddef>
#include <cstdint>

namespace contego::monitor::audit_detail {

// memcpy into the mapped window; false if its pages went away under it
// (see the SIGBUS guard in audit_file.cc).
bool guarded_copy(char* dst, const char* src, size_t n);

constexpr uint64_t kCheckEveryUs = 100000;  // the file is checked this often (on the writer)

}  // namespace contego::monitor::audit_detail

#endif  // CONTEGO_MONITOR_AUDIT_INTERNAL_H_
