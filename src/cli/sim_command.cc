// contego sim SCENARIO: one scenario, protection off and on, CSV + plots + summary.
// With --realtime, the controller is a separate program (after `--`) run
// under the seccomp supervisor while the plant advances in real time.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <fmt/core.h>

#include "cli/command.h"
#include "cli/sim_common.h"
#include "cli/sim_realtime.h"
#include "policy/compile.h"
#include "sim/report.h"
#include "sim/settings.h"

namespace contego::cli {
namespace {

struct Options {
  std::string scenario;
  std::string out = "out/sim";
  int64_t seed = -1;
  bool no_plots = false;
  bool realtime = false;
  std::string protection = "both";
  std::string task;
  std::vector<std::string> program;
};

int run_realtime_command(const Options& o) {
  auto sc = sim::load_scenario(o.scenario);
  if (!sc) {
    fmt::print(stderr, "contego sim: {}\n", sc.error());
    return 1;
  }
  if (o.seed >= 0) sc->seed = static_cast<uint64_t>(o.seed);
  if (o.program.empty()) {
    fmt::print(stderr, "contego sim: --realtime needs the controller program after '--'\n");
    return 2;
  }
  auto compiled = policy::compile_file(sc->policy_path);
  if (!compiled.ok) {
    fmt::print(stderr, "contego sim: {}: the policy does not compile\n", sc->policy_path);
    for (const auto& d : compiled.diagnostics) fmt::print(stderr, "{}\n", d.rendered);
    return 1;
  }
  RealtimeRequest req;
  req.scenario = *sc;
  req.image.bytes = compiled.image;
  for (const auto& t : compiled.model.tasks) req.image.task_names.push_back(t.name);
  req.image.names = monitor::name_table(compiled.model);
  req.task = o.task.empty() ? sim::setting_string(sc->settings, "task", "follower") : o.task;
  req.argv = o.program;
  std::vector<sim::RunResult> runs;
  const std::string stem = sc->name + "-rt";
  for (bool protect : {false, true}) {
    if ((protect && o.protection == "off") || (!protect && o.protection == "on")) continue;
    req.protect = protect;
    req.label = protect ? "protected" : "unprotected";
    req.audit_path = o.out + "/" + stem + "-" + req.label + "-audit.jsonl";
    std::error_code ec;
    std::filesystem::create_directories(o.out, ec);
    fmt::print("running {} in real time, contego {} ...\n", o.program.front(),
               protect ? "on" : "off");
    auto r = run_realtime(req);
    if (!r) {
      fmt::print(stderr, "contego sim: {}\n", r.error());
      return 1;
    }
    runs.push_back(std::move(*r));
  }
  auto traces = sim::write_traces(runs, o.out, stem);
  if (!traces) {
    fmt::print(stderr, "contego sim: {}\n", traces.error());
    return 1;
  }
  if (!o.no_plots && !sim::gnuplot_available()) {
    fmt::print("{}\n", sim::kNoGnuplotNote);
  } else if (!o.no_plots) {
    auto plots = sim::plot_runs(*sc, runs, o.out, stem);
    if (!plots) {
      fmt::print(stderr, "contego sim: {}\n", plots.error());
      return 1;
    }
  }
  fmt::print("{}\nwritten to {} ({}-*)\n", sim::summary_table(*sc, runs), o.out, stem);
  return 0;
}

}  // namespace

void register_sim(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "sim", "Simulate a scenario with protection off and on: CSV traces, plots, summary");
  auto o = std::make_shared<Options>();
  cmd->add_option("SCENARIO", o->scenario, "scenario file (see docs/simulation.md)")->required();
  cmd->add_option("--out", o->out, "directory for traces and figures")->capture_default_str();
  cmd->add_option("--seed", o->seed, "noise seed (default: the scenario's)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-plots", o->no_plots, "write traces and the summary only");
  cmd->add_flag("--realtime", o->realtime,
                "run the controller PROGRAM (after --) under supervision, plant in real time");
  cmd->add_option("--protection", o->protection, "real time: on, off or both")
      ->check(CLI::IsMember({"on", "off", "both"}))
      ->capture_default_str();
  cmd->add_option("--task", o->task, "real time: the program's task name in the policy");
  cmd->add_option("PROGRAM", o->program, "real time: the controller program and its arguments");
  cmd->callback([o] {
    if (o->realtime) {
      set_exit_code(run_realtime_command(*o));
      return;
    }
    if (!o->program.empty()) {
      fmt::print(stderr, "contego sim: a PROGRAM is only used with --realtime\n");
      set_exit_code(2);
      return;
    }
    SimRequest req;
    req.scenario_path = o->scenario;
    req.out_dir = o->out;
    if (o->seed >= 0) req.seed = static_cast<uint64_t>(o->seed);
    req.plots = !o->no_plots;
    auto r = run_scenario_files(req);
    if (!r) {
      fmt::print(stderr, "contego sim: {}\n", r.error());
      set_exit_code(1);
      return;
    }
    fmt::print("{}\n", r->summary);
    if (!r->note.empty()) fmt::print("{}\n", r->note);
    fmt::print("written to {}:\n", o->out);
    for (const auto& f : r->files) fmt::print("  {}\n", f);
  });
}

}  // namespace contego::cli
