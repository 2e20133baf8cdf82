// The overhead measurement behind `contego bench`: the paper's method (a
// control task timing each actuation command with CLOCK_MONOTONIC over many
// trials), applied to every path a command can take here:
//   a  unprotected: the transfer on the virtual bus, called directly;
//   b  preload: the task under libcontego_preload.so, monitor in another process
//      (shared-memory channel; b-sock: the socket only, CONTEGO_CHANNEL=0);
//   c1 seccomp, checker in the supervising process (contego run --policy);
//   c2 seccomp, checker in a separate monitor process (contego run --socket;
//      c2-sock: the socket only, --no-channel);
//   d  the in-process core: Monitor::transfer called directly (decode-free).
// Paths b, c1, c2 run the real contego-bench-task program; a and d are timed
// in this process. The monitor process is forked before any thread starts.
//
// Thread-safety: run() starts and joins its own threads; not reentrant.
#ifndef CONTEGO_PERF_OVERHEAD_H_
#define CONTEGO_PERF_OVERHEAD_H_

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"

namespace contego::perf {

struct Stats {
  size_t n = 0;
  double mean_us = 0, median_us = 0, p99_us = 0, p999_us = 0, worst_us = 0;
};
// Nearest-rank percentiles over nanosecond samples.
Stats summarise(std::vector<uint64_t> ns);

// One control task's actuation command, and what decides it: a compiled
// policy image loaded into the real core (core::Checker), or, with no image,
// the pass-through decider (allow, emit, audit line).
struct Workload {
  std::string name;      // "rover.policy follower", "rover follower (pass-through)" ...
  std::string task;      // task name at the monitor
  uint16_t task_id = 0;  // its id in the image (pass-through: task_ids())
  uint8_t addr = 0;
  std::vector<uint8_t> bytes;  // one write()
  std::vector<uint8_t> image;  // compiled policy; empty = pass-through decider
  // A job of several commands, sent in turn instead of `bytes` (the
  // sequence a policy's invariant expects), with a pause of job_period_us
  // after each job when it is > 0 (at least half the policy's period: the
  // monitor then starts a new job, and a new rate window, for each, and
  // every command can be allowed).
  std::vector<std::vector<uint8_t>> job;
  uint32_t job_period_us = 0;
  // The commands of one job, in order (`job`, or `bytes` alone).
  std::vector<std::vector<uint8_t>> commands() const {
    return job.empty() ? std::vector<std::vector<uint8_t>>{bytes} : job;
  }
};
// The pass-through workloads (rover follower, arm gripper command shapes).
std::vector<Workload> example_workloads();

enum class Path {
  kUnprotected,
  kPreload,
  kPreloadSocket,
  kSeccompInProcess,
  kSeccompMonitor,
  kSeccompMonitorSocket,
  kCore
};
inline constexpr Path kAllPaths[] = {Path::kUnprotected,
                                     Path::kPreload,
                                     Path::kPreloadSocket,
                                     Path::kSeccompInProcess,
                                     Path::kSeccompMonitor,
                                     Path::kSeccompMonitorSocket,
                                     Path::kCore};
const char* path_label(Path p);  // short, for tables and the chart
const char* path_key(Path p);    // JSON key

struct Row {
  std::string workload;
  Path path = Path::kUnprotected;
  Stats stats;
  uint64_t failures = 0;  // commands the task saw fail (must be 0 with the pass-through checker)
  std::map<std::string, uint64_t> decisions;  // from the audit log: allow, ignore, failsafe, reject
  // Every command of the row was allowed (the figures are those of an
  // allowed command; only such rows make the headline and overhead.json).
  bool all_allowed() const;
};

struct DosResult {
  std::string transport;  // "channel", "socket", "channel, SCHED_FIFO"
  std::string skipped;    // why it was not measured (SCHED_FIFO refused), else empty
  uint32_t period_us = 0;
  Stats quiet;        // the periodic task alone
  Stats under_burst;  // while another supervised task bursts
  uint64_t burst_commands = 0;
};

struct Options {
  uint32_t trials = 200;
  std::vector<Workload> workloads;  // empty: example_workloads()
  std::string task_exe;             // contego-bench-task
  std::string preload_lib;          // libcontego_preload.so ("" skips path b)
  bool dos = true;
  uint32_t dos_period_us = 1000;
  uint32_t spin_us = 100;  // channel busy-wait of both ends (gate::SpinPolicy)
  // >= 0: on paths b, c1 and c2 the task program (and on c1 and c2 its
  // supervising thread) run on this CPU only, as `contego run --cpu` does.
  int cpu = -1;
  // Called before and after each row and DoS variant with a line saying
  // which (the CLI prints it on stderr); may be empty.
  std::function<void(const std::string&)> progress;
};

struct Report {
  std::string checker;  // what decided (see run())
  uint32_t trials = 0;
  int cpu = -1;  // Options::cpu
  std::vector<Row> rows;
  std::vector<DosResult> dos;  // one per transport (empty: not measured)
  const Row* find(const std::string& workload, Path p) const;
};

// Runs every workload on every path. A workload with a policy image is
// decided by the real core with that policy (the virtual line follower reads
// the middle of the line, a state the rover's invariants accept); without
// one, by the pass-through decider (allows every command and emits it
// unchanged, with the audit line): the cost of interception, transport,
// decoding, auditing and the bus alone. The DoS measure uses pass-through.
Result<Report> run(const Options& options);

// The human table: mean, median, p99, worst (µs) and added µs vs path a.
std::string table(const Report& report);
// Per workload and path, with the added figures; also the sched overhead.
nlohmann::json to_json(const Report& report);
// What `contego sched --overhead-from` reads: {"overhead_ns", "statistic",
// "statistics_ns": {"median", "p99", "p999", "max"}, "measured_on",
// "method"}. Each statistic is the largest added figure (protected minus
// unprotected, at least 0) of the enforcing deployment path (c2) over the
// workloads whose commands were all allowed (all workloads if none was);
// overhead_ns is the p99.9.
nlohmann::json sched_overhead(const Report& report);
// Writes DATA.dat and the gnuplot script next to `stem`, then stem.svg and
// stem.png. Fails if gnuplot is missing or fails.
Status write_chart(const Report& report, const std::string& stem);

}  // namespace contego::perf

#endif  // CONTEGO_PERF_OVERHEAD_H_
