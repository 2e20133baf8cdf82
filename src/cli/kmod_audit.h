// `contego kmod audit`: contego.ko's audit ring into the hash-chained audit
// log (kmod_audit.cc, docs/kernel-client.md "Audit").
#ifndef CONTEGO_CLI_KMOD_AUDIT_H_
#define CONTEGO_CLI_KMOD_AUDIT_H_

#include <cstdint>
#include <string>

#include "contego_kmod.h"
#include "monitor/audit_log.h"

namespace contego::cli {

struct KmodAuditOptions {
  std::string device = "/dev/contego-audit";
  std::string policy;  // the policy loaded into the module: the records' names
  std::string audit;   // the log ("-" = standard error)
  monitor::AuditOptions audit_options;
  bool quiet = false;
};

// The wall-clock time (CLOCK_REALTIME, µs) of an instant `mono_us` on
// CLOCK_MONOTONIC -- the clock of contego.ko's records -- as of now.
uint64_t decision_wall_us(uint64_t mono_us);

// One module record as a line of `log` (a decision, or an event naming the
// device and the caller). Every line carries the module's time of what it
// records (mono_us, and t_us: that instant on the wall clock), not the time
// the line is written. False: the line is not in the log.
bool write_kmod_record(monitor::AuditLog& log, const monitor::NameTable& names,
                       const contego_kmod_record& record);

// Reads the ring until SIGINT/SIGTERM; 0, or 1 (a record could not be
// written: it stays in the module), or 2 (cannot start).
int kmod_audit(const KmodAuditOptions& options);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_KMOD_AUDIT_H_
