// contego/i2c_plan.h: I2C_RETRIES and I2C_TIMEOUT as i2c-core applies them
// to one transfer, for the monitor's acting transfers; contego.ko links it
// too (the ioctls' limits). Freestanding.
#include "contego/i2c_plan.h"

extern "C" int contego_i2c_try_again(uint32_t err, uint32_t tries, uint32_t retries,
                                     uint64_t elapsed, uint64_t timeout) {
  // __i2c_transfer: for (try = 0; try <= adap->retries; try++) { ret =
  // master_xfer(); if (ret != -EAGAIN) break; if (time_after(jiffies,
  // orig_jiffies + adap->timeout)) break; }
  return err == CONTEGO_EAGAIN && tries <= retries && elapsed <= timeout ? 1 : 0;
}

extern "C" int contego_i2c_timing_arg_ok(int timeout, uint64_t arg) {
  constexpr uint64_t kIntMax = 0x7FFFFFFF;
  return arg <= (timeout ? kIntMax / CONTEGO_I2C_TIMEOUT_UNIT_MS : kIntMax) ? 1 : 0;
}
