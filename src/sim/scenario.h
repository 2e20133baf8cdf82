// Scenario files: one platform, one attack, with protection run off and on.
// The format is documented in docs/simulation.md.
#ifndef CONTEGO_SIM_SCENARIO_H_
#define CONTEGO_SIM_SCENARIO_H_

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "sim/settings.h"
#include "sim/world.h"

namespace contego::sim {

inline constexpr uint64_t kMaxSteps = 1'000'000'000;
inline constexpr uint64_t kMaxTraceRows = 1'000'000;

struct Scenario {
  std::string name;         // file name without directory and extension
  std::string title;        // `title` line, for plots and the summary
  std::string platform;     // rover | arm | tank | pump | camera
  std::string policy_path;  // resolved against the scenario file's directory
  uint64_t duration_us = 30'000'000;
  uint64_t step_us = 1'000;
  uint64_t trace_us = 50'000;
  uint64_t seed = 1;
  Settings settings;
  std::vector<AttackSpec> attacks;
};

// Parses scenario text. `file_name` is used in messages ("file:line: ...");
// relative policy paths are resolved against `base_dir`.
Result<Scenario> parse_scenario(std::string_view text, const std::string& file_name,
                                const std::string& base_dir);
Result<Scenario> load_scenario(const std::string& path);

const std::vector<std::string>& platforms();
// The world of `scenario.platform`, seeded with `seed`.
Result<std::unique_ptr<World>> make_world(const Scenario& scenario, uint64_t seed);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_SCENARIO_H_
