// contego demo: the paper's case studies under attack, with and without
// contego, in one command: rover control spoofing (Fig. 4a), rover DoS burst
// (Fig. 4b), robotic-arm gripper spoofing (Fig. 1).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "base/clock.h"
#include "cli/command.h"
#include "cli/install_paths.h"
#include "cli/sim_common.h"

namespace contego::cli {

void register_demo(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "demo",
      "Run the paper's case studies under attack, protection off and on; write its figures");
  auto out = std::make_shared<std::string>("out/demo");
  cmd->add_option("--out", *out, "directory for the figures and traces")->capture_default_str();
  cmd->callback([out] {
    struct Item {
      const char* scenario;
      const char* figure;
      const char* what;
    };
    const Item items[] = {
        {"scenarios/rover_spoof.scn", "fig4a", "Fig. 4(a): rover under control spoofing"},
        {"scenarios/rover_dos.scn", "fig4b", "Fig. 4(b): rover under a DoS burst"},
        {"scenarios/arm_high_pulse.scn", "fig1", "Fig. 1: robotic arm gripper spoofing"},
    };
    const uint64_t start_us = monotonic_us();
    std::vector<std::string> figures;
    std::string note;
    for (const auto& item : items) {
      SimRequest req;
      req.scenario_path = find_data_file(item.scenario);
      req.out_dir = *out;
      req.stem = item.figure;
      req.figure = item.figure;
      auto r = run_scenario_files(req);
      if (!r) {
        fmt::print(stderr, "contego demo: {}\n", r.error());
        set_exit_code(1);
        return;
      }
      fmt::print("== {}\n{}\n", item.what, r->summary);
      note = r->note;
      if (note.empty()) {
        figures.push_back(*out + "/" + item.figure + ".png");
        figures.push_back(*out + "/" + item.figure + ".svg");
      } else {
        for (const auto& f : r->files) figures.push_back(f);
      }
    }
    const double secs = static_cast<double>(monotonic_us() - start_us) * 1e-6;
    if (note.empty()) {
      fmt::print("figures (traces as CSV beside them):\n");
    } else {
      fmt::print("{}:\n", note);
    }
    for (const auto& f : figures) fmt::print("  {}\n", f);
    fmt::print("done in {:.1f} s\n", secs);
  });
}

}  // namespace contego::cli
