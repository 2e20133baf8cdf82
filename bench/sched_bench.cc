// Google Benchmark of the schedulability analysis: task sets analysed per
// second for 10-, 50- and 200-task sets (random, UUniFast-discard at
// U = 0.7, log-uniform periods 10 ms - 1 s, N 1-5, C^o = 50 us, DM order).
// Build with the release preset for real figures:
//   cmake --build --preset release --target sched_bench && build/release/bench/sched_bench
#include <benchmark/benchmark.h>
#include <vector>

#include "sched/analysis.h"
#include "sched/assign.h"
#include "sched/generate.h"

namespace {

using contego::sched::Analyzer;
using contego::sched::Assignment;
using contego::sched::Generator;
using contego::sched::GenOptions;
using contego::sched::TaskSet;

std::vector<TaskSet> make_sets(size_t tasks, size_t count) {
  GenOptions o;
  o.tasks = tasks;
  Generator gen(1);
  std::vector<TaskSet> sets;
  for (size_t k = 0; k < count; ++k) {
    TaskSet s = gen.generate(o, 0.7);
    for (auto& t : s.tasks) t.overhead = 50'000;
    sets.push_back(assign_priorities(s, Assignment::kDeadlineMonotonic).set);
  }
  return sets;
}

// Full analysis: every task's response time, no early exit.
void BM_Analyse(benchmark::State& state) {
  const auto sets = make_sets(static_cast<size_t>(state.range(0)), 64);
  Analyzer analyzer;
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(analyzer.analyse(sets[k++ % sets.size()]));
  }
  state.counters["task_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Analyse)->Arg(10)->Arg(50)->Arg(200);

// Verdict only (stops at the first miss), as the experiment uses it.
void BM_Schedulable(benchmark::State& state) {
  const auto sets = make_sets(static_cast<size_t>(state.range(0)), 64);
  Analyzer analyzer;
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(analyzer.schedulable(sets[k++ % sets.size()]));
  }
  state.counters["task_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Schedulable)->Arg(10)->Arg(50)->Arg(200);

// Audsley's assignment (n^2 response-time tests in the worst case).
void BM_Audsley(benchmark::State& state) {
  const auto sets = make_sets(static_cast<size_t>(state.range(0)), 16);
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(assign_priorities(sets[k++ % sets.size()], Assignment::kAudsley));
  }
  state.counters["task_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Audsley)->Arg(10)->Arg(50)->Arg(200);

}  // namespace

BENCHMARK_MAIN();
