// Whether a bus can put a transfer on the wire in the form the monitor sends
// it (bus::Bus::expressible over each transaction), asked before the core
// decides and again for what the verdicts send before anything acts (the
// i2c-dev model's rule, contego/i2c_plan.h, which contego.ko applies too):
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

// Ok when `bus` can perform every part of the call `t` (its transactions
// `planned`, from gate::to_transactions(t)) as Monitor::transfer sends it:
// before the core decides, the program's bytes (`verdicts` null); once the
// call acts, what `verdicts` send, before the core's transfer is committed.
// The shared model's rule (contego_i2c_call_has_forms), contego.ko's too.
// Else why not.
Status inexpressible(const bus::Bus& bus, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned,
                     const std::vector<core::Verdict>* verdicts = nullptr);

// Ok when `bus` can send each of the verdict's emits as one write message
// (the shared model's contego_i2c_emits_have_forms). Else why not.
Status emits_inexpressible(const bus::Bus& bus, const core::Verdict& v, bool ten_bit);

// The verdict's one emit, as a message to `read`'s address, when a write
// whose verdict it is goes out together with the read answering it (a
// process call: gate::PlannedTx::answers_write), with a repeated start: the
// write is one message and the pair has a form on `bus`
// (contego_i2c_emit_with_read). Else false, and the two go out apart.
bool emit_goes_with_read(const bus::Bus& bus, const core::Verdict& v, const bus::Msg& read,
                         bus::Msg* emit);

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
