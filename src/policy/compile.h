// The policy compiler's entry point: source text in, verified image out.
#ifndef CONTEGO_POLICY_COMPILE_H_
#define CONTEGO_POLICY_COMPILE_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "devices/profile.h"
#include "image/image_model.h"
#include "policy/diag/diagnostic.h"

namespace contego::policy {

// A finding of an analysis of the task model that the compiler reports as a
// warning (W0708) at the task's declaration (or the first task if `task` is empty).
struct TaskFinding {
  std::string task;
  std::string message;
};

struct CompileOptions {
  bool strict = false;  // warnings are errors
  // Run on the lowered image when set (contego check: the schedulability
  // analysis of src/sched, which src/policy may not depend on).
  std::function<std::vector<TaskFinding>(const image::ImageModel&)> task_model_check;
  // Device profiles by name; empty = devices::find_builtin_profile (tests inject their own).
  std::function<const devices::ProfileSpec*(std::string_view)> profiles;
};

// What `contego check` prints besides the image: the policy as the compiler
// understood it, in readable form.
struct PolicySummary {
  struct Device {
    std::string name, profile, role;  // role: "actuator", "sensor", "actuator+sensor"
    uint8_t bus = 0;
    uint16_t addr = 0;
    std::vector<std::string> safe;  // safe-state commands as written
    std::string latch;              // "" or "after 3 within 1000000us"
  };
  struct Task {
    std::string name, exe;
    std::string user, group, unit, cgroup;  // who may run it (the monitor checks)
    uint32_t sessions = 1;
    std::optional<uint32_t> phase_us;  // declared job phase (the monitor's grid)
    uint8_t ignore_errno = 0;          // `ignore_errno`: what an ignored call fails with; 0: none
  };
  std::vector<Device> devices;
  std::vector<Task> tasks;
  std::vector<std::string> signals;     // "pos = derived (program of 42 instructions)"
  std::vector<std::string> rates;       // each rate limit as written
  std::vector<std::string> invariants;  // each invariant as written
};

struct CompileOutput {
  bool ok = false;                      // no errors (and, if strict, no warnings)
  std::vector<Diagnostic> diagnostics;  // all of them, in source order
  image::ImageModel model;              // valid when ok
  std::vector<uint8_t> image;           // serialised and accepted by core::Checker::load
  uint32_t worst_case_cost = 0;         // bytecode instructions of one check, from the verifier
  uint32_t estimated_cost = 0;          // the compiler's own bound (equal unless a bug)
  PolicySummary summary;                // filled when the policy got past semantic checks
  // The device profiles as lowered, by device id (built-in or built from a
  // `regmap` declaration): what tools use to encode commands and samples.
  std::vector<devices::ProfileSpec> profiles;
};

CompileOutput compile_source(const std::string& file_name, const std::string& text,
                             const CompileOptions& options = {});
CompileOutput compile_file(const std::string& path, const CompileOptions& options = {});

}  // namespace contego::policy

#endif  // CONTEGO_POLICY_COMPILE_H_
