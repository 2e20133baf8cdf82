#include "cli/sim_common.h"

#include "policy/compile.h"
#include "sim/monitor_guard.h"
#include "sim/report.h"

namespace contego::cli {

Result<ScenarioOutcome> run_scenario_files(const SimRequest& req) {
  auto sc = sim::load_scenario(req.scenario_path);
  if (!sc) return make_error(sc.error());
  ScenarioOutcome out;
  out.scenario = *sc;

  auto compiled = policy::compile_file(sc->policy_path);
  if (!compiled.ok) {
    std::string msg = sc->policy_path + ": the policy does not compile";
    for (const auto& d : compiled.diagnostics) {
      if (d.severity == "error") msg += "\n" + (d.rendered.empty() ? d.message : d.rendered);
    }
    return make_error(msg);
  }
  sim::PolicyImage image;
  image.bytes = compiled.image;
  for (const auto& t : compiled.model.tasks) image.task_names.push_back(t.name);
  image.names = monitor::name_table(compiled.model);

  auto guard = [&image](bool observe) -> sim::GuardFactory {
    return [&image, observe](bus::VirtualBus& bus) -> Result<std::unique_ptr<sim::Guard>> {
      auto g = sim::MonitorGuard::create(image, bus, observe);
      if (!g) return make_error(g.error());
      return std::unique_ptr<sim::Guard>(std::move(*g));
    };
  };
  // The reference is the attack-free mission with contego on (the policy may
  // correct honest commands too: its "violations seen" are false positives).
  // Protection off still runs the checker in observe mode, so the summary
  // can say when the first violation reached the plant.
  const sim::RunOptions runs[] = {{"baseline", false, guard(false), req.seed},
                                  {"unprotected", true, guard(true), req.seed},
                                  {"protected", true, guard(false), req.seed}};
  for (const auto& opt : runs) {
    auto r = sim::run_scenario(*sc, opt);
    if (!r) return make_error(sc->name + " (" + opt.label + "): " + r.error());
    out.runs.push_back(std::move(*r));
  }
  const std::string stem = req.stem.empty() ? sc->name : req.stem;
  auto traces = sim::write_traces(out.runs, req.out_dir, stem);
  if (!traces) return make_error(traces.error());
  out.files = *traces;
  if (req.plots && !sim::gnuplot_available()) {
    out.note = sim::kNoGnuplotNote;
  } else if (req.plots) {
    auto plots = sim::plot_runs(*sc, out.runs, req.out_dir, stem, req.figure);
    if (!plots) return make_error(plots.error());
    out.files.insert(out.files.end(), plots->begin(), plots->end());
  }
  out.summary = sim::summary_table(*sc, out.runs);
  return out;
}

}  // namespace contego::cli
