#include "cli/sim_realtime.h"

#include <atomic>
#include <chrono>
#include <thread>

#include "intercept/seccomp/supervisor.h"
#include "monitor/monitor.h"

namespace contego::cli {

Result<sim::RunResult> run_realtime(const RealtimeRequest& req) {
  const sim::Scenario& sc = req.scenario;
  auto made = sim::make_world(sc, sc.seed);
  if (!made) return make_error(made.error());
  std::unique_ptr<sim::World> world = std::move(*made);
  bus::VirtualBus vbus;
  world->attach(vbus);

  auto decider = std::make_unique<sim::SimDecider>(req.protect, monotonic_us());
  if (Status st = decider->load(req.image); !st) return make_error(st.error());
  uint16_t task = core::kNoTask;
  for (size_t i = 0; i < req.image.task_names.size(); ++i) {
    if (req.image.task_names[i] == req.task) task = static_cast<uint16_t>(i);
  }
  if (task == core::kNoTask) return make_error("the policy declares no task '" + req.task + "'");

  monitor::AuditLog audit;
  if (!req.audit_path.empty()) {
    auto st = audit.open(req.audit_path);
    if (!st) return make_error(st.error());
  }
  monitor::Monitor mon(*decider, audit);
  mon.add_bus(1, &vbus);
  mon.set_names(req.image.names);
  if (!req.protect) mon.set_drop_report(nullptr);  // nothing is dropped: no drop lines
  mon.set_task_names(req.image.task_names);
  mon.sample_all();
  mon.start_sampling();

  sim::RunResult result;
  result.label = req.label;
  result.columns.push_back("time_s");
  for (auto& c : world->columns()) result.columns.push_back(c);

  // The plant: a fixed step in real time, under the bus lock so the monitor
  // never sees a half-updated device. Late steps are caught up at once.
  std::atomic<bool> stop{false};
  std::thread plant([&] {
    // The plant's clock starts with the program's first bus transfer, so
    // that times in the program (its attack window) and in the trace agree
    // however long the interpreter takes to start.
    while (!stop.load() && mon.decisions() == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const uint64_t t0_us = monotonic_us();
    const uint64_t limit = sc.duration_us + 1'000'000;
    for (uint64_t t = sc.step_us; !stop.load() && t <= limit; t += sc.step_us) {
      MonotonicClock::instance().sleep_until_us(t0_us + t);
      vbus.with_lock([&] {
        world->step(t, sc.step_us);
        if (t % sc.trace_us == 0) {
          std::vector<double> row{static_cast<double>(t) * 1e-6};
          for (double v : world->sample()) row.push_back(v);
          result.rows.push_back(std::move(row));
        }
      });
    }
  });

  intercept::seccomp::Options opts;
  opts.task = task;
  opts.argv = req.argv;
  auto rr = intercept::seccomp::run(opts, mon);
  stop = true;
  plant.join();
  mon.stop_sampling();
  if (!rr) return make_error("running " + req.argv.front() + ": " + rr.error());
  if (rr->exit_code != 0 || rr->signal != 0) {
    return make_error(req.argv.front() + " failed (exit " + std::to_string(rr->exit_code) +
                      ", signal " + std::to_string(rr->signal) + ")");
  }
  result.metrics = world->metrics();
  result.stats = decider->stats();
  return result;
}

}  // namespace contego::cli
