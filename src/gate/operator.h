// Requests an operator sends to a running monitor over its socket (not a
// task's traffic): `contego reset DEVICE` clears a latched device, `contego
// status` reads its state, `contego reload` replaces its policy in place.
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

// Asks the monitor at `socket_path` to enforce the policy bundle `bundle`
// (minisign `signature`, empty: none) in place of its own, keeping sessions
// and state (`contego reload`). The monitor's account of what it kept and
// started afresh. Granted to root and to the monitor's own uid only.
Result<std::string> request_reload(const std::string& socket_path, const std::string& bundle,
                                   const std::string& signature);

}  // namespace contego::gate

#endif  // CONTEGO_GATE_OPERATOR_H_
