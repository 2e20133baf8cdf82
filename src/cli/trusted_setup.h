// What `contego run` and `contego monitor` share: compile the policy, load it
// into the core, open the buses (real /dev/i2c-N or a virtual bus with the
// built-in device models) and build the monitor.
#ifndef CONTEGO_CLI_TRUSTED_SETUP_H_
#define CONTEGO_CLI_TRUSTED_SETUP_H_

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "bus/virtual_bus.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"

namespace contego::monitor {

struct SetupOptions {
  std::string policy;                     // policy source file
  std::string audit = "-";                // audit log path ("-" = stderr)
  std::map<int, std::string> real_buses;  // bus number -> /dev/i2c-N
  std::vector<int> virtual_buses;  // buses hosting PCA9685 0x40, GoPiGo2 0x08, line follower 0x06
  uint32_t budget_factor = Monitor::kDefaultBudgetFactor;  // set_budget_factor (0 = off)
};

struct Trusted {
  std::unique_ptr<CoreDecider> decider;
  AuditLog audit;
  std::vector<std::unique_ptr<bus::Bus>> buses;
  std::unique_ptr<Monitor> monitor;
  std::map<std::string, uint16_t> tasks;  // name -> id
};

// Fails with a message naming the file and the reason (diagnostics, verifier status).
Result<std::unique_ptr<Trusted>> setup(const SetupOptions& options);

}  // namespace contego::monitor

#endif  // CONTEGO_CLI_TRUSTED_SETUP_H_
