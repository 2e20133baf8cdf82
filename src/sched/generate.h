// Random task sets for schedulability experiments: UUniFast-discard
// utilisations (Bini & Buttazzo; Davis & Burns' discard variant for sums
// near or above 1), log-uniform periods, implicit or constrained deadlines,
// uniform numbers of checked commands. Seeded and deterministic: the same
// seed and options give the same sets on every machine with the same
// standard library (std::mt19937_64 is fully specified; the real
// distributions are not, so a different libstdc++ may differ).
//
// Host code, floating point only in generation (never in a verdict).
#ifndef CONTEGO_SCHED_GENERATE_H_
#define CONTEGO_SCHED_GENERATE_H_

#include <cstdint>
#include <random>
#include <vector>

#include "base/result.h"
#include "sched/task_set.h"

namespace contego::sched {

struct GenOptions {
  size_t tasks = 20;
  Nanos period_min = 10 * kNanosPerMilli;
  Nanos period_max = 1000 * kNanosPerMilli;
  Nanos period_granularity = kNanosPerMicro;  // periods are multiples of this
  bool constrained = false;                   // D uniform in [C_i, T_i] instead of D = T
  int64_t actuations_min = 1;
  int64_t actuations_max = 5;
};

Status validate(const GenOptions& options);

class Generator {
 public:
  explicit Generator(uint64_t seed) : rng_(seed) {}

  // n utilisations in (0, 1] summing to `total` (UUniFast, retried while any
  // exceeds 1). REQUIRES: 0 < total <= n.
  std::vector<double> uunifast_discard(size_t n, double total);

  // One set at (checking-free) utilisation `total`; priorities 0 (assign
  // them), overheads unset. C_i is at least 1 ns. REQUIRES: validate(options).
  TaskSet generate(const GenOptions& options, double total);

 private:
  std::mt19937_64 rng_;
};

}  // namespace contego::sched

#endif  // CONTEGO_SCHED_GENERATE_H_
