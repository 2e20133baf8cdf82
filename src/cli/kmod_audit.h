// `contego kmod audit`: contego.ko's audit ring into the hash-chained audit
// log (kmod_audit.cc, docs/kernel-client.md "Audit").
#ifndef CONTEGO_CLI_KMOD_AUDIT_H_
#define CONTEGO_CLI_KMOD_AUDIT_H_

#include <cstdint>
#include <linux/contego_kmod.h>
#include <string>
#include <vector>

#include "monitor/audit_log.h"

namespace contego::cli {

struct KmodAuditOptions {
  std::string device = "/dev/contego-audit";
  // The policies the module may run: each record is named from the image in
  // force (KmodNames).
  std::vector<std::string> policies;
  std::vector<std::string> bundles;  // the same from policy bundles
  std::string audit;                 // the log ("-" = standard error)
  monitor::AuditOptions audit_options;
  bool quiet = false;
  // Prometheus metrics of the module's state (kmod_status.h), written at
  // start, every interval and at the stop; read through `control`.
  std::string metrics_file;
  unsigned metrics_interval_s = 15;
  std::string control = "/dev/contego";
};

// The wall-clock time (CLOCK_REALTIME, µs) of an instant `mono_us` on
// CLOCK_MONOTONIC -- the clock of contego.ko's records -- as of now.
uint64_t decision_wall_us(uint64_t mono_us);

// The names records are written with: those of the image in force, as the
// module's policy-load records say (the CRC-32 in its image header, matched
// against each policy the reader was given). Before the first policy-load
// record the first policy's names are assumed (the reader is started with
// the policy it loads); after one whose image is none of them, records carry
// numbers only, never another policy's names.
class KmodNames {
 public:
  struct Image {
    std::string source;
    uint32_t crc = 0;
    monitor::NameTable names;
  };
  explicit KmodNames(std::vector<Image> images);
  // Follows a policy-load record, and a load refused after it for a safe
  // state not driven (others change nothing); returns what its line says
  // about the names ("" for other records).
  std::string follow(const contego_kmod_record& record);
  const monitor::NameTable& current() const { return *current_; }

 private:
  std::string switch_to(uint32_t crc, const char* again);
  std::vector<Image> images_;
  monitor::NameTable none_;
  const monitor::NameTable* current_;
};

// One module record as a line of `log` (a decision, or an event naming the
// device and the caller). Every line carries the module's time of what it
// records (mono_us, and t_us: that instant on the wall clock), not the time
// the line is written. False: the line is not in the log.
bool write_kmod_record(monitor::AuditLog& log, const monitor::NameTable& names,
                       const contego_kmod_record& record, const std::string& load_note = {});

// Reads the ring until SIGINT/SIGTERM; 0, or 1 (a record could not be
// written: it stays in the module), or 2 (cannot start).
int kmod_audit(const KmodAuditOptions& options);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_KMOD_AUDIT_H_
