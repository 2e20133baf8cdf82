// What the intercept tests that run a real Monitor share: a temporary audit
// log, a policy compiled and loaded into the decider, reading a log back,
// and stopping the socket server they serve it through.
#ifndef CONTEGO_TESTS_INTERCEPT_TEST_SUPPORT_H_
#define CONTEGO_TESTS_INTERCEPT_TEST_SUPPORT_H_

#include <unistd.h>

#include <cstddef>
#include <fstream>
#include <gtest/gtest.h>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/server.h"
#include "policy/compile.h"

namespace contego::test_support {

// Opens `audit` on a fresh empty file named after `pattern` (ending in
// XXXXXX); its name goes to *path. Call under ASSERT_NO_FATAL_FAILURE.
inline void open_temp_audit(monitor::AuditLog& audit, std::string* path, std::string pattern) {
  const int fd = mkstemp(pattern.data());
  ASSERT_GE(fd, 0);
  close(fd);
  *path = pattern;
  ASSERT_TRUE(audit.open(*path).ok());
}

// Compiles the policy at `path` and loads its image into `decider`. Call
// under ASSERT_NO_FATAL_FAILURE.
inline void load_policy(const std::string& path, monitor::CoreDecider& decider,
                        policy::CompileOutput* out) {
  *out = policy::compile_file(path);
  ASSERT_TRUE(out->ok) << path << (out->diagnostics.empty() ? "" : out->diagnostics[0].rendered);
  ASSERT_EQ(
      decider.checker().load(out->image.data(), static_cast<uint32_t>(out->image.size())).status,
      core::LoadStatus::kOk);
}

inline std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Names the instances of a test parameterised by an enum: names[param], the
// names in the order of the enum's values.
template <size_t N>
auto enum_param_names(const char* const (&names)[N]) {
  return [&names](const auto& info) { return std::string(names[static_cast<size_t>(info.param)]); };
}

// Stops a test's server (if it was started) and joins the thread serving it.
inline void stop_server(monitor::Server* server, std::thread& thread) {
  if (!server) return;
  server->stop();
  thread.join();
}

}  // namespace contego::test_support

#endif  // CONTEGO_TESTS_INTERCEPT_TEST_SUPPORT_H_
