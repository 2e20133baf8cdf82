// The audit-log options `contego monitor` and `contego run` share.
#ifndef CONTEGO_CLI_AUDIT_ARGS_H_
#define CONTEGO_CLI_AUDIT_ARGS_H_

#include "monitor/audit_log.h"

namespace CLI {
class App;
}

namespace contego::cli {

// --audit-unsafe, --audit-max-bytes and --audit-keep, written to `options`.
void add_audit_options(CLI::App* cmd, monitor::AuditOptions* options);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_AUDIT_ARGS_H_
