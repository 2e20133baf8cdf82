// The classic experiment of the real-time literature, with checking cost:
// the fraction of random task sets found schedulable against their
// (checking-free) utilisation, one curve per per-command overhead C^o.
//
// Host code, single-threaded.
#ifndef CONTEGO_SCHED_EXPERIMENT_H_
#define CONTEGO_SCHED_EXPERIMENT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "base/result.h"
#include "sched/assign.h"
#include "sched/generate.h"

namespace contego::sched {

struct ExperimentOptions {
  GenOptions generator;
  std::vector<Nanos> overheads = {0, 50 * kNanosPerMicro, 100 * kNanosPerMicro,
                                  200 * kNanosPerMicro, 500 * kNanosPerMicro};
  double u_min = 0.05;
  double u_max = 1.0;
  double u_step = 0.05;
  int64_t sets_per_point = 5000;
  // DM by default: optimal for D <= T with this test (docs/sched.md), and
  // the same order as RM for implicit deadlines.
  Assignment assignment = Assignment::kDeadlineMonotonic;
  uint64_t seed = 1;
};

struct ExperimentRow {
  double utilisation = 0;
  Nanos overhead = 0;
  int64_t sets = 0;
  int64_t schedulable = 0;
  double ratio() const {
    return sets == 0 ? 0.0 : static_cast<double>(schedulable) / static_cast<double>(sets);
  }
};

struct ExperimentResult {
  std::vector<ExperimentRow> rows;  // overhead-major, then utilisation
  int64_t sets = 0;                 // task sets generated
  int64_t analyses = 0;             // sets x overheads
};

Status validate(const ExperimentOptions& options);

// Every generated set is analysed at every overhead (the same sets for each
// curve, so the curves differ only by C^o). REQUIRES: validate(options).
ExperimentResult run_experiment(const ExperimentOptions& options);

// utilisation,overhead_ns,overhead,sets,schedulable,ratio
std::string experiment_csv(const ExperimentResult& result);

// A gnuplot script that reads `csv_path` and writes the figure to
// `svg_path` and `png_path`.
std::string experiment_gnuplot(const ExperimentResult& result, const ExperimentOptions& options,
                               const std::string& csv_path, const std::string& svg_path,
                               const std::string& png_path);

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_EXPERIMENT_H_
