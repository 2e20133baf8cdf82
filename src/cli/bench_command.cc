// `contego bench`: the overhead measurement (see src/perf/overhead.h).
//
//   contego bench [--trials N] [--out-dir DIR] [--no-dos] [--no-chart]
//                 [--policy-dir DIR] [--no-pass-through]
//
// The workloads are the example control tasks decided by their compiled
// policies (policies/rover.policy task follower, policies/arm.policy task
// gripper) in the real core, and the same command shapes under the
// pass-through decider for comparison (the plumbing alone).
//
// Prints the table, writes DIR/bench.json (every figure), DIR/overhead.json
// (for `contego sched --overhead-from`) and DIR/overhead.svg/.png (gnuplot).
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <sys/stat.h>

#include "base/json_text.h"
#include "cli/command.h"
#include "cli/install_paths.h"
#include "gate/channel.h"
#include "perf/overhead.h"
#ifdef CONTEGO_HAVE_POLICY
#include "policy/compile.h"
#endif

namespace contego::cli {
namespace {

struct BenchArgs {
  uint32_t trials = 10000;
  std::string out_dir = "bench-out";
  bool no_dos = false;
  bool no_chart = false;
  uint32_t spin_us = perf::Options{}.spin_us;
  // Beside the executable: in its build tree or its install prefix.
  std::string task_exe = install_paths().bench_task;
  std::string preload = install_paths().preload;
  std::string policy_dir = install_paths().data_dir + "/policies";
  bool no_pass_through = false;
};

// A workload decided by the compiled example policy `file` in the real core.
Result<perf::Workload> policy_workload(const std::string& dir, const std::string& file,
                                       const std::string& task, uint8_t addr,
                                       std::vector<uint8_t> bytes) {
#ifdef CONTEGO_HAVE_POLICY
  const std::string path = dir + "/" + file;
  const policy::CompileOutput out = policy::compile_file(path);
  if (!out.ok) return make_error("policy " + path + " does not compile");
  perf::Workload w;
  w.name = file + " " + task;
  w.task = task;
  w.addr = addr;
  w.bytes = std::move(bytes);
  w.image = out.image;
  for (size_t i = 0; i < out.model.tasks.size(); ++i) {
    if (out.model.tasks[i].name == task) {
      w.task_id = static_cast<uint16_t>(i);
      return w;
    }
  }
  return make_error("policy " + path + " has no task " + task);
#else
  (void)addr;
  (void)bytes;
  return make_error("this contego was built without the policy compiler; cannot load " + dir + "/" +
                    file + " for task " + task);
#endif
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out);
}

void bench(const BenchArgs& a) {
  perf::Options o;
  o.trials = a.trials;
  o.task_exe = a.task_exe;
  o.preload_lib = a.preload;
  o.dos = !a.no_dos;
  o.spin_us = a.spin_us;
  if (!a.policy_dir.empty()) {
    // rover.policy's INV3 expects set_left_speed(80) first while the line is
    // under the middle sensor; arm.policy's GRIP sequence starts at 420.
    auto rover = policy_workload(a.policy_dir, "rover.policy", "follower", 0x08,
                                 {0x01, 0x46, 80, 0x00, 0x00});
    auto arm = policy_workload(a.policy_dir, "arm.policy", "gripper", 0x40,
                               {0x1A, 0x00, 0x00, 0xA4, 0x01});
    for (auto* w : {&rover, &arm}) {
      if (!w->ok()) {
        fmt::print(stderr, "contego bench: {}\n", w->error());
        return set_exit_code(1);
      }
      o.workloads.push_back(**w);
    }
  }
  if (!a.no_pass_through || o.workloads.empty()) {
    for (const perf::Workload& w : perf::example_workloads()) o.workloads.push_back(w);
  }
  auto report = perf::run(o);
  if (!report.ok()) {
    fmt::print(stderr, "contego bench: {}\n", report.error());
    return set_exit_code(1);
  }
  fmt::print("{}", perf::table(*report));
  mkdir(a.out_dir.c_str(), 0755);
  const std::string json = a.out_dir + "/bench.json", overhead = a.out_dir + "/overhead.json";
  if (!write_file(json, json_text(perf::to_json(*report), 2) + "\n") ||
      !write_file(overhead, json_text(perf::sched_overhead(*report), 2) + "\n")) {
    fmt::print(stderr, "contego bench: cannot write into {}\n", a.out_dir);
    return set_exit_code(1);
  }
  fmt::print("\nwrote {} and {} (contego sched --overhead-from {})\n", json, overhead, overhead);
  if (!a.no_chart) {
    if (Status s = perf::write_chart(*report, a.out_dir + "/overhead"); !s.ok()) {
      fmt::print(stderr, "contego bench: {}\n", s.error());
      return set_exit_code(1);
    }
    fmt::print("wrote {0}/overhead.svg and {0}/overhead.png\n", a.out_dir);
  }
}

}  // namespace

void register_bench(CLI::App& app) {
  auto args = std::make_shared<BenchArgs>();
  auto* cmd = app.add_subcommand(
      "bench", "Measure the added time per checked actuation command on every enforcement path");
  cmd->add_option("--trials", args->trials, "commands per workload and path (default 10000)")
      ->check(CLI::Range(1u, 1000000u));
  cmd->add_option("--out-dir", args->out_dir, "where bench.json, overhead.json and the chart go");
  cmd->add_flag("--no-dos", args->no_dos, "skip the DoS measurement");
  cmd->add_flag("--no-chart", args->no_chart, "do not run gnuplot");
  cmd->add_option("--spin-us", args->spin_us,
                  "busy-wait of both ends of a shared-memory channel before they sleep")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  cmd->add_option("--task-program", args->task_exe, "the timed task program (contego-bench-task)");
  cmd->add_option("--policy-dir", args->policy_dir,
                  "where rover.policy and arm.policy are (empty: pass-through rows only)");
  cmd->add_flag("--no-pass-through", args->no_pass_through,
                "time only the compiled example policies, not the pass-through decider");
  cmd->add_option("--preload-lib", args->preload,
                  "libcontego_preload.so; an empty value skips the preload path");
  cmd->callback([args] { bench(*args); });
}

}  // namespace contego::cli
