// `contego bench`: the overhead measurement (see src/perf/overhead.h).
//
//   contego bench [--trials N] [--out-dir DIR] [--no-dos] [--no-chart]
//                 [--policy-dir DIR] [--no-pass-through] [--quiet]
//   contego bench --per-job [--jobs N] [--period-us P] [--commands-per-job K]
//                 [--out-dir DIR] [--no-chart] [--policy-dir DIR] [--quiet]
//
// The workloads are the example control tasks decided by their compiled
// policies (policies/rover.policy task follower, policies/arm.policy task
// gripper) in the real core, and the same command shapes under the
// pass-through decider for comparison (the plumbing alone). The rover
// sends its invariant's sequence (both speeds, then fwd) as one job every
// 2 ms, so every command is allowed (see rover_workload). A line per row
// goes to stderr as the bench proceeds (--quiet: none).
//
// --per-job is the paper's measure instead (src/perf/per_job.h): the rover
// follower as a periodic task (rover.policy recompiled with period P), K
// commands per job, J jobs on every path, interleaved; prints the added
// time per job beside the paper's and writes DIR/per-job.json and the CDF
// (DIR/per-job.dat, .gp; .svg and .png when gnuplot is there).
//
// Prints the table, writes DIR/bench.json (every figure), DIR/overhead.json
// (for `contego sched --overhead-from`) and DIR/overhead.svg/.png (gnuplot).
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <sys/stat.h>

#include "base/json_text.h"
#include "base/read_file.h"
#include "cli/command.h"
#include "cli/install_paths.h"
#include "gate/channel.h"
#include "perf/overhead.h"
#include "perf/per_job.h"
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
  int cpu = -1;
  // Beside the executable: in its build tree or its install prefix.
  std::string task_exe = install_paths().bench_task;
  std::string preload = install_paths().preload;
  std::string policy_dir = install_paths().data_dir + "/policies";
  bool no_pass_through = false;
  bool quiet = false;
  bool per_job = false;
  uint32_t jobs = perf::PerJobOptions{}.jobs;
  uint32_t period_us = perf::PerJobOptions{}.period_us;
  uint32_t commands_per_job = perf::PerJobOptions{}.per_job;
};

// rover.policy's follower declares a 100 ms period (the window of its rate:
// the vendor loop is free-running), and a sleep ends a job only after half a
// period: at 3 commands per job, 10,000 commands would take 6 minutes. The bench compiles the
// policy with a 2 ms period instead (same devices, rate limits and invariants).
constexpr const char* kRoverTiming = "period 100ms; deadline 100ms; wcet 40ms";
constexpr const char* kBenchRoverTiming = "period 2ms; deadline 2ms; wcet 400us";
constexpr uint32_t kBenchRoverPeriodUs = 2000;

// A workload decided by the compiled example policy `file` in the real core;
// `timing` (from, to) rewrites one line of the policy first.
Result<perf::Workload> policy_workload(const std::string& dir, const std::string& file,
                                       const std::string& task, uint8_t addr,
                                       std::vector<uint8_t> bytes,
                                       std::pair<std::string, std::string> timing = {}) {
#ifdef CONTEGO_HAVE_POLICY
  const std::string path = dir + "/" + file;
  Result<std::string> text = read_input_file(path);
  if (!text) return make_error(text.error());
  if (!timing.first.empty()) {
    const size_t at = text->find(timing.first);
    if (at == std::string::npos) {
      return make_error(path + ": the bench expects the line '" + timing.first + "' (task " + task +
                        ") to shorten its period; the policy changed");
    }
    text->replace(at, timing.first.size(), timing.second);
  }
  const policy::CompileOutput out = policy::compile_source(path, *text);
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
  (void)timing;
  return make_error("this contego was built without the policy compiler; cannot load " + dir + "/" +
                    file + " for task " + task);
#endif
}

// Says what failed, as contego bench, and exits with 1.
void fail(const std::string& message) {
  fmt::print(stderr, "contego bench: {}\n", message);
  set_exit_code(1);
}

// What every path of the bench takes from the command line alike.
template <typename Options>
void set_common_options(const BenchArgs& a, Options& o) {
  o.task_exe = a.task_exe;
  o.preload_lib = a.preload;
  o.spin_us = a.spin_us;
  o.cpu = a.cpu;
  if (!a.quiet) {
    o.progress = [](const std::string& line) { fmt::print(stderr, "contego bench: {}\n", line); };
  }
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  return static_cast<bool>(out);
}

// The rover's job: rover.policy's INV3 expects set_left_speed(80),
// set_right_speed(80), fwd() in each job while the line is under the middle
// sensor, at most 3 per job.
const std::vector<std::vector<uint8_t>> kRoverJob = {
    {0x01, 0x46, 80, 0x00, 0x00}, {0x01, 0x47, 80, 0x00, 0x00}, {0x01, 0x69, 0x00, 0x00, 0x00}};

// The gripper's job: Adafruit_PCA9685's set_pwm(0, 0, 420), one register
// per write, as the 6DOF arm's library sends it (with the chip's
// auto-increment off, as it powers up, a 5-byte write would land whole in
// LED0_ON_L and be held, never checked as a pulse). The first three are
// staged, the fourth completes the pulse, checked by SERVO_WINDOW; channel 0,
// as GRIP's sequence is on channel 5. The policy allows one pulse per job:
// its 1 s period becomes 2 ms, as the rover's.
const std::vector<std::vector<uint8_t>> kArmJob = {
    {0x06, 0x00}, {0x07, 0x00}, {0x08, 420 & 0xFF}, {0x09, 420 >> 8}};
constexpr const char* kArmTiming = "period 1s; deadline 1s; wcet 20ms";
constexpr const char* kBenchArmTiming = "period 2ms; deadline 2ms; wcet 400us";

void bench_per_job(const BenchArgs& a) {
  perf::PerJobOptions o;
  o.jobs = a.jobs;
  o.period_us = a.period_us;
  o.per_job = a.commands_per_job;
  set_common_options(a, o);
  if (a.policy_dir.empty()) {
    o.workload = perf::example_workloads()[0];
  } else {
    const std::string timing =
        fmt::format("period {0}us; deadline {0}us; wcet {1}us", a.period_us, a.period_us / 5);
    auto rover = policy_workload(a.policy_dir, "rover.policy", "follower", 0x08, kRoverJob[0],
                                 {kRoverTiming, timing});  // fwd() is 0x69
    if (!rover.ok()) return fail(rover.error());
    o.workload = *rover;
  }
  o.workload.job = kRoverJob;
  auto report = perf::run_per_job(o);
  if (!report.ok()) return fail(report.error());
  fmt::print("{}", perf::per_job_table(*report));
  mkdir(a.out_dir.c_str(), 0755);
  const std::string json = a.out_dir + "/per-job.json";
  if (!write_file(json, json_text(perf::per_job_json(*report), 2) + "\n")) {
    return fail("cannot write into " + a.out_dir);
  }
  fmt::print("\nwrote {}\n", json);
  if (!a.no_chart) {
    auto cdf = perf::write_per_job_cdf(*report, a.out_dir + "/per-job");
    if (!cdf.ok()) return fail(cdf.error());
    fmt::print("{}\n", *cdf);
  }
}

void bench(const BenchArgs& a) {
  if (a.per_job) return bench_per_job(a);
  perf::Options o;
  o.trials = a.trials;
  o.dos = !a.no_dos;
  set_common_options(a, o);
  if (!a.policy_dir.empty()) {
    // The rover sends kRoverJob, the gripper kArmJob, each a job per 2 ms.
    auto rover = policy_workload(a.policy_dir, "rover.policy", "follower", 0x08,
                                 {0x01, 0x46, 80, 0x00, 0x00}, {kRoverTiming, kBenchRoverTiming});
    if (rover.ok()) {
      rover->job = kRoverJob;
      rover->job_period_us = kBenchRoverPeriodUs;
    }
    auto arm = policy_workload(a.policy_dir, "arm.policy", "gripper", 0x40, kArmJob[0],
                               {kArmTiming, kBenchArmTiming});
    if (arm.ok()) {
      arm->job = kArmJob;
      arm->job_period_us = kBenchRoverPeriodUs;
    }
    for (auto* w : {&rover, &arm}) {
      if (!w->ok()) return fail(w->error());
      o.workloads.push_back(**w);
    }
  }
  if (!a.no_pass_through || o.workloads.empty()) {
    for (const perf::Workload& w : perf::example_workloads()) o.workloads.push_back(w);
  }
  auto report = perf::run(o);
  if (!report.ok()) return fail(report.error());
  fmt::print("{}", perf::table(*report));
  mkdir(a.out_dir.c_str(), 0755);
  const std::string json = a.out_dir + "/bench.json", overhead = a.out_dir + "/overhead.json";
  if (!write_file(json, json_text(perf::to_json(*report), 2) + "\n") ||
      !write_file(overhead, json_text(perf::sched_overhead(*report), 2) + "\n")) {
    return fail("cannot write into " + a.out_dir);
  }
  fmt::print("\nwrote {} and {} (contego sched --overhead-from {})\n", json, overhead, overhead);
  if (!a.no_chart) {
    if (Status s = perf::write_chart(*report, a.out_dir + "/overhead"); !s.ok()) {
      return fail(s.error());
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
  cmd->add_flag("--quiet", args->quiet, "no progress lines on stderr");
  cmd->add_option("--spin-us", args->spin_us,
                  "busy-wait of both ends of a shared-memory channel before they sleep")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  cmd->add_option("--cpu", args->cpu,
                  "on paths b, c1 and c2, run the task (and its supervisor) on this CPU only, as "
                  "`contego run --cpu N` does (default: wherever the scheduler puts them)")
      ->check(CLI::Range(0, 1023));
  cmd->add_option("--task-program", args->task_exe, "the timed task program (contego-bench-task)");
  cmd->add_option("--policy-dir", args->policy_dir,
                  "where rover.policy and arm.policy are (empty: pass-through rows only)");
  cmd->add_flag("--no-pass-through", args->no_pass_through,
                "time only the compiled example policies, not the pass-through decider");
  cmd->add_option("--preload-lib", args->preload,
                  "libcontego_preload.so; an empty value skips the preload path");
  cmd->add_flag("--per-job", args->per_job,
                "the paper's measure: added time per job of a periodic task, every path "
                "interleaved (CDF plot)");
  cmd->add_option("--jobs", args->jobs, "--per-job: jobs per path (default 10000)")
      ->check(CLI::Range(1u, 1000000u));
  cmd->add_option("--period-us", args->period_us, "--per-job: the task's period (default 10000)")
      ->check(CLI::Range(1000u, 1000000u));
  cmd->add_option("--commands-per-job", args->commands_per_job,
                  "--per-job: checked commands per job (default 3, the rover's sequence cycled)")
      ->check(CLI::Range(1u, 1000u));
  cmd->callback([args] { bench(*args); });
}

}  // namespace contego::cli
