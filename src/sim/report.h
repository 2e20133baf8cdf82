// Outputs of a scenario run: CSV traces, gnuplot figures and the summary
// table. Formatting is fixed-precision so equal runs give equal bytes.
#ifndef CONTEGO_SIM_REPORT_H_
#define CONTEGO_SIM_REPORT_H_

#include <string>
#include <vector>

#include "base/result.h"
#include "sim/runner.h"
#include "sim/scenario.h"

namespace contego::sim {

// The trace as CSV text: header "time_s,<columns>", one row per trace period.
std::string trace_csv(const RunResult& run);
// Device-side events ("time_s,event,value").
std::string events_csv(const RunResult& run);
// Every bus operation with the guard's decision.
std::string ops_csv(const RunResult& run);

Status write_file(const std::string& path, const std::string& text);

// Writes <dir>/<stem>-<label>.csv, -<label>-events.csv and -<label>-ops.csv
// for every run. Returns the paths written.
Result<std::vector<std::string>> write_traces(const std::vector<RunResult>& runs,
                                              const std::string& dir, const std::string& stem);

// Whether `gnuplot` is on PATH: plots are optional (the package only
// suggests gnuplot); without it the traces are written and no figure is drawn.
bool gnuplot_available();
inline constexpr const char* kNoGnuplotNote =
    "gnuplot is not installed: wrote the traces (CSV) only; `apt-get install gnuplot-nox` draws "
    "the figures";

// Writes <dir>/<stem>.gp and renders <stem>.svg and <stem>.png with gnuplot
// (the CSV traces must already be in `dir`). `figure` names the layout:
// "auto" picks the platform's; "fig1", "fig4a", "fig4b" are the paper's.
Result<std::vector<std::string>> plot_runs(const Scenario& scenario,
                                           const std::vector<RunResult>& runs,
                                           const std::string& dir, const std::string& stem,
                                           const std::string& figure = "auto");

// The summary table (one row per metric, one column per run) as text.
std::string summary_table(const Scenario& scenario, const std::vector<RunResult>& runs);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_REPORT_H_
