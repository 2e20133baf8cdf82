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
// one write message, [register byte] + the read message, or a write and the
// read answering it together (apart when they have no form together). Else
// why not.
Status inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned);

// Ok when `bus` can send each of the verdict's emits as one write message.
Status emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit);

// The verdict's one emit, as a message to `read`'s address, when a write
// whose verdict it is goes out together with the read answering it (a
// process call: gate::PlannedTx::answers_write), with a repeated start: the
// write is one message and the pair has a form on `bus`. Else false, and
// the two go out apart.
bool emit_goes_with_read(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read,
                         bus::Msg* emit);

// emits_inexpressible for a write whose read answers it: ok when the two go
// out together, or each apart.
Status pair_inexpressible(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read);

// Whether write `p` goes out exactly as the program sent it: its verdict's
// emits are its own bytes at its address (contego_i2c_emits_as_sent), so it
// goes out as the program's one message.
bool write_as_sent(const core::Verdict& v, const gate::PlannedTx& p);

// Whether every write of a call goes out as sent: then the call can go out
// as the program's one combined transfer.
bool acts_as_sent(const std::vector<gate::PlannedTx>& planned,
                  const std::vector<core::Verdict>& verdicts);

// The read message of transaction `p` of `t`, its buffer left out (to plan it).
bus::Msg read_message(const gate::Transfer& t, const gate::PlannedTx& p);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_EXPRESSIBLE_H_
