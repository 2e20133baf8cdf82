// The per-job bench behind `contego bench --per-job`: the paper's measure.
// A periodic control task (period P, N checked commands per job) runs for
// J jobs on every path of overhead.h at once (a unprotected, d in-process
// core, c1 seccomp + checker, c2 seccomp + monitor process, b preload),
// each released on the same CLOCK_MONOTONIC grid in its own slot of the
// period, so the paths' jobs interleave in one run and meet the same
// machine. A job's time runs from its wake-up to the end of its last
// write(); the added time per job is a protected path's figure minus path
// a's (avg, p99, worst), printed beside the paper's for the same statistic
// (Contego-TEE, its rover control tasks at a 200 ms period over 10,000
// trials: avg 19.55 to 19.60 ms, p99 22.87 to 23.31, worst 34.11 to 43.47).
//
// Thread-safety: run_per_job() starts and joins its own threads; not reentrant.
#ifndef CONTEGO_PERF_PER_JOB_H_
#define CONTEGO_PERF_PER_JOB_H_

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/result.h"
#include "perf/overhead.h"

namespace contego::perf {

struct PerJobOptions {
  uint32_t jobs = 10000;
  uint32_t period_us = 10000;
  uint32_t per_job = 3;     // commands per job: the workload's job, cycled
  Workload workload;        // a policy image decides; none: pass-through
  std::string task_exe;     // contego-bench-task
  std::string preload_lib;  // "" skips path b
  uint32_t spin_us = 100;
  int cpu = -1;  // >= 0: the task (and its supervisor) on this CPU only, as Options::cpu
  std::function<void(const std::string&)> progress;  // may be empty
};

// One job of a path, by its release instant (CLOCK_MONOTONIC, as `perf
// record -k CLOCK_MONOTONIC` stamps its events): a slow job can be lined up
// with a trace of what else ran then.
struct SlowJob {
  uint32_t job = 0;  // 0-based
  uint64_t release_ns = 0;
  uint64_t job_ns = 0;
};

// The `count` slowest of `job_ns` (in job order; job j released at
// first_release_ns + j * period_ns), slowest first, the earlier job first
// among equals.
std::vector<SlowJob> slowest_jobs(const std::vector<uint64_t>& job_ns, uint64_t first_release_ns,
                                  uint64_t period_ns, size_t count);

struct PerJobRow {
  Path path = Path::kUnprotected;
  Stats stats;                   // per job
  std::vector<uint64_t> job_ns;  // every job's time, sorted (the CDF)
  std::vector<SlowJob> slowest;  // kSlowestKept, slowest first
  uint64_t failures = 0;
  std::map<std::string, uint64_t> decisions;  // from the audit log
};

inline constexpr size_t kSlowestKept = 10;

struct PerJobReport {
  std::string workload;
  uint32_t jobs = 0, period_us = 0, per_job = 0;
  int cpu = -1;
  std::vector<PerJobRow> rows;  // path a first
  const PerJobRow* find(Path p) const;
};

// The paper's figures (ms): added time per job of its periodic control
// tasks (the GoPiGo vendor's, 200 ms period, one actuation per period let
// through). Its text gives each statistic as a range over those tasks, not
// per task: each pair is that range, so a row is compared with the same
// statistic, never the lowest average beside the highest p99.
struct PaperFigures {
  double avg_ms[2] = {19.55, 19.60}, p99_ms[2] = {22.87, 23.31}, worst_ms[2] = {34.11, 43.47};
  uint32_t trials = 10000, period_ms = 200;
};

Result<PerJobReport> run_per_job(const PerJobOptions& options);

// The table: per path avg / median / p99 / worst per job, the added avg /
// p99 / worst against path a, the decisions, the paper's line, and when
// each protected path's slowest job was released.
std::string per_job_table(const PerJobReport& report);
nlohmann::json per_job_json(const PerJobReport& report);
// Writes stem.dat (per path: job time µs and cumulative fraction, one
// gnuplot block per path) and stem.gp; then, if gnuplot is on PATH, draws
// stem.svg and stem.png. Returns a line saying what it wrote or skipped.
Result<std::string> write_per_job_cdf(const PerJobReport& report, const std::string& stem);

}  // namespace contego::perf

#endif  // CONTEGO_PERF_PER_JOB_H_
