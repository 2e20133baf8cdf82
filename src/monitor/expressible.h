// Whether a bus can put a transfer on the wire in the form the monitor sends
// it (bus::Bus::expressible over each transaction), asked before the core
// decides and again for a verdict's substitute bytes before anything acts:
// on an SMBus-only adapter a transfer with no SMBus form is refused whole,
// with the reason for the audit log, and no part of it acts.
#ifndef CONTEGO_MONITOR_EXPRESSIBLE_H_
#define CONTEGO_MONITOR_EXPRESSIBLE_H_

#include <string>
#include <vector>

#include "contego/core/verdict.h"

#include "bus/bus.h"
#include "gate/transfer.h"

namespace contego::monitor {

// Ok when `bus` can perform every transaction of `planned` (from
// gate::to_transactions(t)) as Monitor::transfer sends it: a quick command,
// one write message, or [register byte] + the read message. Else why not.
Status inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned);

// Ok when `bus` can send each of the verdict's emits as one write message.
Status emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_EXPRESSIBLE_H_
