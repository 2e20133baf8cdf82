// How the monitor tries an acting bus operation again on a lost
// arbitration: the descriptor's own I2C_RETRIES and I2C_TIMEOUT, by the
// shared model's rule (contego/i2c_plan.h, contego_i2c_try_again).
#ifndef CONTEGO_MONITOR_RETRY_H_
#define CONTEGO_MONITOR_RETRY_H_

#include <cstdint>

#include "contego/i2c_plan.h"

#include "base/clock.h"
#include "gate/transfer.h"

namespace contego::monitor {

// One acting bus operation of a call (`attempt`: 0 or an errno), tried again
// on a lost arbitration by i2c-core's rule with the descriptor's own
// I2C_RETRIES and I2C_TIMEOUT (contego_i2c_try_again), timed by the
// monitor's clock; once if it set none. The adapter's own values are left
// alone (setting them is adapter-wide), and apply inside each try. Unlike
// contego.ko, which holds one adapter meanwhile, the monitor holds its lock,
// every bus's checks: no call is retried past one period of its task
// (`cap_us`; 0: no period), whose job is over by then anyway.
template <typename Attempt>
int try_by(const gate::Timing& timing, uint64_t cap_us, const Clock& clock, Attempt attempt) {
  const uint64_t start = timing.own ? clock.now_us() : 0;
  uint64_t timeout_us = uint64_t{timing.timeout_10ms} * CONTEGO_I2C_TIMEOUT_UNIT_MS * 1000;
  if (cap_us != 0 && cap_us < timeout_us) timeout_us = cap_us;
  int err = attempt();
  for (uint32_t tries = 1; timing.own && contego_i2c_try_again(err, tries, timing.retries,
                                                               clock.now_us() - start, timeout_us);
       ++tries) {
    err = attempt();
  }
  return err;
}

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_RETRY_H_
