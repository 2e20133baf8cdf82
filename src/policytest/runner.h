// Runs a parsed test file against a compiled policy image with the real
// trusted core (core::Checker), one fresh checker per case, and reports a
// verdict table and rule coverage.
//
// Host code: allocates; not real-time.
#ifndef CONTEGO_POLICYTEST_RUNNER_H_
#define CONTEGO_POLICYTEST_RUNNER_H_

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "contego/core/host.h"  // before image.h: see test_file.h

#include "base/result.h"
#include "devices/profile.h"
#include "image/image_model.h"
#include "policytest/test_file.h"

namespace contego::policytest {

struct StepOutcome {
  std::string case_name;
  uint32_t line = 0;
  std::string step;      // as written
  std::string expected;  // as written
  std::string got;       // "allow", "failsafe set_left_speed(speed=80)", "reject EPERM"
  std::string rule;      // deciding rule: invariant / rate name, "access", "latch" or "-"
  std::string reason;    // core::reason_name of the verdict
  bool pass = false;
  std::string detail;  // why it failed
};

struct RunReport {
  std::string file_name;
  std::vector<StepOutcome> steps;
  std::vector<std::string> errors;  // file:line:col: problems with the test file vs the policy
  size_t cases = 0;
  size_t failed_cases = 0;
  std::vector<std::string> invariants;            // all, in image order
  std::vector<std::string> uncovered_invariants;  // no step was decided by them
  std::vector<std::string> rates;
  std::vector<std::string> uncovered_rates;
  bool ok() const { return errors.empty() && failed_cases == 0; }
};

// Loads `image` into a core::Checker for every case (an image the verifier
// refuses is an error) and runs the case's steps in order. `model` is the
// same image's model: it names tasks, devices, commands and rules.
// `profiles` are the device profiles by device id as the compiler used them
// (they name the sample fields of declared sensors); when empty they are
// recovered from the model (devices::profile_from_model).
Result<RunReport> run_tests(const TestFile& file, const image::ImageModel& model,
                            std::span<const uint8_t> image,
                            std::span<const devices::ProfileSpec> profiles = {});

// The verdict table, then errors, coverage and a summary line.
std::string format_report(const RunReport& report);

}  // namespace contego::policytest

#endif  // CONTEGO_POLICYTEST_RUNNER_H_
