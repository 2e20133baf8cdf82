#include "sim/runner.h"

#include <algorithm>

#include "sim/sim_bus.h"

namespace contego::sim {

void RunStats::count(bool write, core::Decision acted, bool violation, uint64_t t_us) {
  if (write) {
    ++writes;
    uint64_t* const by_decision[] = {&allowed, &ignored, &replaced, &rejected};  // core::Decision
    ++*by_decision[static_cast<size_t>(acted) & 3];
  } else {
    ++reads;
  }
  if (!violation) return;
  ++violations;
  if (!first_violation_us) first_violation_us = t_us;
}

namespace {

class GuardedPort : public Port {
 public:
  GuardedPort(Guard& guard, World& world, RunResult& result)
      : guard_(guard), world_(world), result_(result) {}

  void set_context(uint64_t now_us, bool injected) {
    now_us_ = now_us;
    injected_ = injected;
  }

  bool write(const std::string& task, const BusOp& op) override {
    GuardResult g = guard_.perform(task, op, now_us_);
    result_.stats.count(true, g.decision, g.violation, now_us_);
    if (injected_) ++result_.stats.injected;
    for (const auto& e : g.emits) world_.on_write(now_us_, g.addr, e);
    record(task, op, g, false);
    return g.decision != core::Decision::kReject;
  }

  std::optional<std::vector<uint8_t>> read(const std::string& task, const BusOp& op) override {
    GuardResult g = guard_.perform(task, op, now_us_);
    result_.stats.count(false, g.decision, g.violation, now_us_);
    record(task, op, g, true);
    if (g.decision != core::Decision::kAllow) return std::nullopt;
    return std::move(g.data);
  }

 private:
  void record(const std::string& task, const BusOp& op, const GuardResult& g, bool read) {
    result_.ops.push_back(OpRecord{now_us_, task, op.addr, read, op.bytes, injected_, g.decision,
                                   g.reason, g.violation, g.emits});
  }

  Guard& guard_;
  World& world_;
  RunResult& result_;
  uint64_t now_us_ = 0;
  bool injected_ = false;
};

struct Pending {
  TimedOp op;
  uint64_t order;  // insertion order breaks ties between equal times
};

}  // namespace

GuardResult PassThroughGuard::perform(const std::string&, const BusOp& op, uint64_t) {
  GuardResult r;
  r.addr = op.addr;
  if (op.kind == BusOp::Kind::kWrite) {
    if (bus_write(bus_, op.addr, op.bytes) == 0) r.emits.push_back(op.bytes);
    return r;
  }
  // A register pointer goes first in the same combined transfer, as I2C_RDWR does it.
  std::vector<uint8_t> out(op.read_len);
  if (bus_read(bus_, op.addr, op.bytes, out) == 0) r.data = std::move(out);
  return r;
}

Result<RunResult> run_scenario(const Scenario& sc, const RunOptions& options) {
  const uint64_t seed = options.seed.value_or(sc.seed);
  auto made = make_world(sc, seed);
  if (!made) return make_error(made.error());
  std::unique_ptr<World> world = std::move(*made);
  bus::VirtualBus bus;
  world->attach(bus);

  std::unique_ptr<Guard> guard;
  if (options.guard) {
    auto g = options.guard(bus);
    if (!g) return make_error(g.error());
    guard = std::move(*g);
  } else {
    guard = std::make_unique<PassThroughGuard>(bus);
  }

  std::vector<std::unique_ptr<Attack>> attacks;
  if (options.attacks) {
    for (const auto& spec : sc.attacks) {
      auto a = world->make_attack(spec);
      if (!a) return make_error(sc.name + ": " + a.error());
      attacks.push_back(std::move(*a));
    }
  }
  Noise attack_noise(derive_seed(seed, 99));

  RunResult result;
  result.label = options.label;
  result.columns.push_back("time_s");
  for (auto& c : world->columns()) result.columns.push_back(c);

  GuardedPort port(*guard, *world, result);
  auto controllers = world->controllers();
  std::vector<uint64_t> next_release;
  for (auto* c : controllers) next_release.push_back(c->offset_us());
  std::vector<uint64_t> job_count(controllers.size(), 0);
  std::vector<Pending> pending;
  uint64_t order = 0;

  for (uint64_t now = 0; now <= sc.duration_us; now += sc.step_us) {
    guard->tick(now);
    // Release the jobs that are due: reads now, writes scheduled.
    for (size_t i = 0; i < controllers.size(); ++i) {
      while (next_release[i] <= now) {
        Job job{++job_count[i], next_release[i]};
        next_release[i] += controllers[i]->period_us();
        std::vector<TimedOp> ops;
        guard->released(controllers[i]->task(), now);
        port.set_context(now, false);
        controllers[i]->release(job, port, ops);
        for (auto& a : attacks) a->apply(job, controllers[i]->task(), ops, attack_noise);
        for (auto& op : ops) pending.push_back({std::move(op), order++});
      }
    }
    // Perform the scheduled operations that are due, in time order.
    std::stable_sort(pending.begin(), pending.end(), [](const Pending& a, const Pending& b) {
      return a.op.at_us != b.op.at_us ? a.op.at_us < b.op.at_us : a.order < b.order;
    });
    size_t done = 0;
    while (done < pending.size() && pending[done].op.at_us <= now) {
      auto& p = pending[done++];
      port.set_context(now, p.op.injected);
      if (p.op.op.kind == BusOp::Kind::kWrite) {
        port.write(p.op.task, p.op.op);
      } else {
        (void)port.read(p.op.task, p.op.op);
      }
    }
    pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(done));

    if (now > 0) world->step(now, sc.step_us);
    if (now % sc.trace_us == 0) {
      std::vector<double> row{static_cast<double>(now) * 1e-6};
      for (double v : world->sample()) row.push_back(v);
      result.rows.push_back(std::move(row));
    }
  }
  result.events = world->events();
  result.metrics = world->metrics();
  return result;
}

}  // namespace contego::sim
