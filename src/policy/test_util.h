// Helpers shared by the policy compiler's unit tests.
#ifndef CONTEGO_POLICY_TEST_UTIL_H_
#define CONTEGO_POLICY_TEST_UTIL_H_

#include <cstddef>
#include <cstdint>

#include "contego/core/transaction.h"

namespace contego::policy::testing {

// A write of `len` bytes at `bytes` by task `task` to `addr` on bus 1, in
// job `job`, at `now_us`.
inline core::Transaction write_tx(uint16_t task, uint16_t addr, uint32_t job, const uint8_t* bytes,
                                  size_t len, uint64_t now_us = 0) {
  core::Transaction tx{};
  tx.task = task;
  tx.bus = 1;
  tx.kind = core::TxKind::kWrite;
  tx.addr = addr;
  tx.job = job;
  tx.len = static_cast<uint32_t>(len);
  tx.bytes = bytes;
  tx.now_us = now_us;
  return tx;
}

}  // namespace contego::policy::testing

#endif  // CONTEGO_POLICY_TEST_UTIL_H_
