// Real-time mode of `contego sim`: the controller is a separate, unmodified
// program under the seccomp supervisor (as `contego run` runs it), the
// monitor decides in-process with the compiled policy, and the scenario's
// plant advances in real time on the monitor's virtual bus.
#ifndef CONTEGO_CLI_SIM_REALTIME_H_
#define CONTEGO_CLI_SIM_REALTIME_H_

#include <string>
#include <vector>

#include "base/result.h"
#include "sim/runner.h"
#include "sim/scenario.h"
#include "sim/sim_decider.h"

namespace contego::cli {

struct RealtimeRequest {
  sim::Scenario scenario;
  sim::PolicyImage image;
  bool protect = true;            // false: the checker only watches (observe mode)
  std::string task;               // the program's task name in the policy
  std::vector<std::string> argv;  // the program
  std::string label;              // run label ("protected" ...)
  std::string audit_path;         // audit log (empty: none)
};

// Runs the program to completion (the plant runs until it exits, at most
// the scenario's duration plus a grace second) and returns the trace.
Result<sim::RunResult> run_realtime(const RealtimeRequest& request);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_SIM_REALTIME_H_
