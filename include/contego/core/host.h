// The one narrow interface through which the trusted core reaches its host
// (monitor process, test harness, OP-TEE pseudo-TA, kernel module). The core
// makes no other call out. Plain function pointers so the C facade and a
// kernel can fill it in.
//
// RT-safety contract for implementers: every callback is called from inside
// Checker::check() and must be bounded, non-blocking and must not call back
// into the checker.
#ifndef CONTEGO_CORE_HOST_H_
#define CONTEGO_CORE_HOST_H_

#include <stdint.h>

#include "contego/core/verdict.h"

namespace contego::core {

struct Host {
  void* context;

  // Copies the latest sample of sensor `device` (the raw bytes the host read
  // from the bus with the device's sample request) into `buf`. Returns the
  // number of bytes copied (0 = no sample yet) and the time it was taken.
  // May be null: every signal is then unavailable.
  uint32_t (*read_sample)(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                          uint64_t* taken_at_us);

  // Receives one record per decoded command. May be null (no audit).
  void (*audit)(void* context, const AuditRecord* record);
};

}  // namespace contego::core

#endif  // CONTEGO_CORE_HOST_H_
