// The trusted daemon's command line and its main loop, shared by the
// `contego-monitor` binary (which runs it) and `contego monitor` (which
// parses the same options, compiles --policy into a bundle and executes
// contego-monitor with it: the process that decides never links the
// policy compiler, the simulator or the other tools).
#ifndef CONTEGO_CLI_MONITOR_DAEMON_H_
#define CONTEGO_CLI_MONITOR_DAEMON_H_

#include <cstdint>
#include <string>
#include <vector>

#include "gate/channel.h"
#include "monitor/audit_log.h"
#include "monitor/monitor.h"
#include "monitor/server.h"

namespace CLI {
class App;
}

namespace contego::cli {

struct MonitorArgs {
  std::string policy, image, image_sha256, bundle;
  int bundle_fd = -1;  // set by `contego monitor` only
  bool require_signed = false;
  std::string signature, keys_dir = "/etc/contego/keys";
  std::string socket = "/run/contego/monitor.sock", audit = "-";
  std::vector<std::string> buses;
  std::vector<int> virtual_buses;
  std::vector<unsigned> uids;
  std::string status_socket;  // the read-only status socket, if any
  std::string status_group;   // name or gid: may read the status
  uint32_t spin_us = gate::SpinPolicy{}.spin_us;
  bool realtime = false;
  bool allow_degraded = false;
  bool complain = false;
  std::vector<std::string> complain_for;
  std::string virtual_state;  // tests: the virtual devices' state, written at exit
  uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
  bool budget_factor_given = false;  // on the command line (a bundle's must agree)
  monitor::AuditOptions audit_options;
  monitor::ServerLimits limits;
  std::string metrics_file;
  uint32_t metrics_interval_s = 15;
  std::string checkpoint_key;  // minisign secret key: signed checkpoints in the log
  uint32_t checkpoint_interval_s = 3600;
};

// Every option of the monitor on `cmd`. `daemon`: contego-monitor's own
// parser (--bundle-fd, and --policy meaning the policy that bundle came from).
void add_monitor_options(CLI::App* cmd, MonitorArgs* args, bool daemon);

// What is wrong with the arguments, before anything is opened ("" if nothing).
std::string monitor_usage_error(const MonitorArgs& args, bool daemon);

// Loads the bundle or pinned image, sets up the buses, serves until
// SIGINT/SIGTERM, drives the safe state. Returns the exit code.
int run_monitor_daemon(const MonitorArgs& args);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_MONITOR_DAEMON_H_
