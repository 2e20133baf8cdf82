// Fuzzes the policy test-file parser: any text must parse or produce errors
// with valid positions, never crash, hang or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "policytest/test_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  contego::policytest::ParseResult r = contego::policytest::parse_test_file("fuzz.test", text);
  // Every error points inside the input (line count + 1 for an error at EOF).
  size_t lines = 1;
  for (char c : text) lines += c == '\n' ? 1 : 0;
  for (const auto& e : r.errors) {
    if (e.loc.line < 1 || e.loc.line > lines + 1 || e.loc.column < 1) std::abort();
  }
  return 0;
}
