// `contego bench`: the overhead measurement (see src/perf/overhead.h).
//
//   contego bench [--trials N] [--out-dir DIR] [--no-dos] [--no-chart]
//
// Prints the table, writes DIR/bench.json (every figure), DIR/overhead.json
// (for `contego sched --overhead-from`) and DIR/overhead.svg/.png (gnuplot).
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <sys/stat.h>

#include "base/json_text.h"
#include "cli/command.h"
#include "perf/overhead.h"

namespace contego::cli {
namespace {

struct BenchArgs {
  uint32_t trials = 10000;
  std::string out_dir = "bench-out";
  bool no_dos = false;
  bool no_chart = false;
  std::string task_exe = CONTEGO_BENCH_TASK_PATH;
  std::string preload = CONTEGO_PRELOAD_PATH;
};

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
  cmd->add_option("--task-program", args->task_exe, "the timed task program (contego-bench-task)");
  cmd->add_option("--preload-lib", args->preload,
                  "libcontego_preload.so; an empty value skips the preload path");
  cmd->callback([args] { bench(*args); });
}

}  // namespace contego::cli
