// What `contego sim` and `contego demo` share: run one scenario three times
// (attack-free, attacked with protection off, attacked with protection on),
// all through the policy compiled from the scenario's policy file, and
// write its traces, figure and summary.
#ifndef CONTEGO_CLI_SIM_COMMON_H_
#define CONTEGO_CLI_SIM_COMMON_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "sim/runner.h"
#include "sim/scenario.h"

namespace contego::cli {

struct ScenarioOutcome {
  sim::Scenario scenario;
  std::vector<sim::RunResult> runs;  // baseline, unprotected, protected
  std::vector<std::string> files;    // everything written
  std::string summary;
  std::string note;  // e.g. why no plot was drawn
};

struct SimRequest {
  std::string scenario_path;
  std::string out_dir;
  std::optional<uint64_t> seed;
  std::string stem;             // output file stem; default: the scenario's name
  std::string figure = "auto";  // plot layout (see sim::plot_runs)
  bool plots = true;
};

Result<ScenarioOutcome> run_scenario_files(const SimRequest& request);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_SIM_COMMON_H_
