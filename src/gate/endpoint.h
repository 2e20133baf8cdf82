// Endpoint: the trusted side as an enclave client sees it. Implemented by the
// monitor itself (in-process call, `contego run` without a daemon) and by
// SocketClient (a separate monitor process). An implementation must fail
// closed: if it cannot reach the trusted side, transfer() answers an errno
// and performs nothing.
#ifndef CONTEGO_GATE_ENDPOINT_H_
#define CONTEGO_GATE_ENDPOINT_H_

#include <cstdint>

#include "gate/transfer.h"

namespace contego::gate {

class Endpoint {
 public:
  virtual ~Endpoint() = default;
  // Checks and performs one transfer for `task`.
  virtual TransferReply transfer(uint16_t task, const Transfer& transfer) = 0;
  // The task finished a job (its periodic sleep).
  virtual void job_boundary(uint16_t task) = 0;
  // A supervised task is gone: its actuators go to their safe state.
  virtual void task_exited(uint16_t task) = 0;
  // Whether bus N exists on the trusted side, and its I2C_FUNCS mask.
  virtual bool has_bus(uint8_t bus) = 0;
  virtual uint64_t funcs(uint8_t bus) = 0;
};

}  // namespace contego::gate

#endif  // CONTEGO_GATE_ENDPOINT_H_
