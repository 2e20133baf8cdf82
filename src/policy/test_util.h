// Helpers shared by the policy compiler's unit tests.
#ifndef CONTEGO_POLICY_TEST_UTIL_H_
#define CONTEGO_POLICY_TEST_UTIL_H_

#include <cstddef>
#include <cstdint>
#include <gtest/gtest.h>
#include <memory>
#include <string>

#include "contego/core/checker.h"
#include "contego/core/transaction.h"

#include "policy/compile.h"

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

// Compiles `text` (as the file `name`) into *out and loads its image into a
// new Checker, *checker. Call under ASSERT_NO_FATAL_FAILURE.
inline void compile_and_load(const std::string& name, const std::string& text, CompileOutput* out,
                             std::unique_ptr<core::Checker>* checker) {
  *out = compile_source(name, text);
  ASSERT_TRUE(out->ok) << (out->diagnostics.empty() ? "" : out->diagnostics[0].rendered);
  *checker = std::make_unique<core::Checker>();
  ASSERT_EQ((*checker)->load(out->image.data(), static_cast<uint32_t>(out->image.size())).status,
            core::LoadStatus::kOk);
}

}  // namespace contego::policy::testing

#endif  // CONTEGO_POLICY_TEST_UTIL_H_
