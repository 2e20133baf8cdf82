// Requests an operator sends to a running monitor over its socket (not a
// task's traffic): `contego reset DEVICE` clears a latched device.
#ifndef CONTEGO_GATE_OPERATOR_H_
#define CONTEGO_GATE_OPERATOR_H_

#include <string>

#include "base/result.h"

namespace contego::gate {

// Asks the monitor at `socket_path` to clear the latch of `device` (its name
// in the policy). True if it was latched. The monitor grants it to root and
// to its own uid only, and audits every request.
Result<bool> request_reset(const std::string& socket_path, const std::string& device);

// Asks the monitor at `socket_path` for its state (`contego status`): JSON
// text. Granted to root and to the monitor's own uid only.
Result<std::string> request_status(const std::string& socket_path);

}  // namespace contego::gate

#endif  // CONTEGO_GATE_OPERATOR_H_
