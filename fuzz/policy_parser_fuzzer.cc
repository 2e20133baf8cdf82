// Fuzzes the whole policy compiler: any text must compile or produce
// diagnostics with valid positions, never crash, hang or read out of bounds.
// Two properties beyond "no crash":
//  - every diagnostic points inside the input (line <= lines + 1, column >= 1);
//  - the compiler never emits an image its own core verifier refuses
//    (E0901 is an internal compiler error: a bug, so the fuzzer aborts).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "policy/compile.h"
#include "policy/diag/diag.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 64 * 1024) return 0;  // policies are small; keep iterations fast
  const std::string text(reinterpret_cast<const char*>(data), size);
  const contego::policy::CompileOutput out = contego::policy::compile_source("fuzz.policy", text);
  size_t lines = 1;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  for (const auto& d : out.diagnostics) {
    if (d.id == "E0901") std::abort();
    if (d.line < 1 || d.line > lines + 1 || d.column < 1 || d.end_column < d.column) std::abort();
  }
  if (out.ok && out.image.empty()) std::abort();
  (void)contego::policy::render_json(out.diagnostics);
  return 0;
}
