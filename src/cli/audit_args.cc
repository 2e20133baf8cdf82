#include "cli/audit_args.h"

#include <CLI/CLI.hpp>

namespace contego::cli {

void add_audit_options(CLI::App* cmd, monitor::AuditOptions* options) {
  cmd->add_flag("--audit-unsafe", options->allow_unsafe,
                "allow an audit target that is not a regular file (a FIFO, a device): written "
                "line by line, not locked, checked or rotated");
  cmd->add_option("--audit-max-bytes", options->max_bytes,
                  "rotate the audit log before it exceeds this many bytes (LOG -> LOG.1 ...; the "
                  "hash chain continues in the new file; 0 = never)")
      ->capture_default_str();
  cmd->add_option("--audit-keep", options->keep, "rotated audit files kept (LOG.1 newest .. LOG.N)")
      ->check(CLI::Range(1u, 1000u))
      ->capture_default_str();
}

}  // namespace contego::cli
