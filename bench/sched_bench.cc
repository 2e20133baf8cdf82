// Google Benchmark of the schedulability analysis: task sets analysed per
// second for 10-, 50- and 200-task sets (random, UUniFast-discard at
// U = 0.7, log-uniform periods 10 ms - 1 s, N 1-5, C^o = 50 us, DM order),
// the sensitivity search, and `contego sched --batch`'s stream against the
// library's own parse + analyse.
//
// Before the benchmarks, a comparison over the same random sets in the same
// run (5-50 tasks, U 0.3-0.95; --compare-sets=N, default 2000):
//   - the library against a plain response-time test written below, with
//     the full model (C^TEE and blocking); the verdicts must be identical,
//     else the bench exits 1;
//   - the batch stream against parse + analyse of the same JSON lines;
//   - the sensitivity search (and the binary search it replaced, on a
//     tenth of the sets) in units of one analysis of the same set.
// Build with the release preset for real figures:
//   cmake --build --preset release --target sched_bench && build/release/bench/sched_bench
#include <algorithm>
#include <benchmark/benchmark.h>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "sched/analysis.h"
#include "sched/assign.h"
#include "sched/batch.h"
#include "sched/generate.h"
#include "sched/reader.h"
#include "sched/sensitivity.h"

namespace {

using contego::sched::Analyzer;
using contego::sched::Assignment;
using contego::sched::Generator;
using contego::sched::GenOptions;
using contego::sched::Nanos;
using contego::sched::Task;
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

// Sets of 5-50 tasks at U 0.3-0.95, C^o 50 us, DM priorities.
std::vector<TaskSet> mixed_sets(size_t count) {
  Generator gen(2);
  std::mt19937_64 rng(2);
  std::vector<TaskSet> sets;
  for (size_t k = 0; k < count; ++k) {
    GenOptions o;
    o.tasks = 5 + rng() % 46;
    TaskSet s = gen.generate(o, 0.3 + 0.65 * static_cast<double>(rng() % 1000) / 1000.0);
    for (auto& t : s.tasks) t.overhead = 50'000;
    sets.push_back(assign_priorities(s, Assignment::kDeadlineMonotonic).set);
  }
  return sets;
}

// The plain response-time test with the full model, written here without
// the library: C^TEE = C + N C^o, B = max N_j C_j^o over strictly lower
// priorities, equal priorities interfere, iteration stops beyond D.
class PlainRta {
 public:
  bool schedulable(const TaskSet& set) { return run(set, nullptr); }
  // Every task's response time (the first iterate beyond D_i for a task
  // that misses), no early exit: the work of the library's analyse().
  bool response_times(const TaskSet& set, std::vector<Nanos>& out) { return run(set, &out); }

 private:
  bool run(const TaskSet& set, std::vector<Nanos>* all) {
    const size_t n = set.tasks.size();
    if (all != nullptr) all->assign(n, 0);
    bool met = true;
    idx_.resize(n);
    std::iota(idx_.begin(), idx_.end(), size_t{0});
    std::sort(idx_.begin(), idx_.end(),
              [&](size_t a, size_t b) { return set.tasks[a].priority > set.tasks[b].priority; });
    c_.resize(n);
    t_.resize(n);
    for (size_t p = 0; p < n; ++p) {
      const Task& x = set.tasks[idx_[p]];
      c_[p] = x.wcet + x.actuations * x.overhead;
      t_[p] = x.period;
    }
    block_.assign(n + 1, 0);
    for (size_t p = n; p-- > 0;) {
      const Task& x = set.tasks[idx_[p]];
      block_[p] = std::max(block_[p + 1], x.actuations * x.overhead);
    }
    for (size_t p = 0; p < n; ++p) {
      const Task& x = set.tasks[idx_[p]];
      size_t end = p + 1;
      while (end < n && set.tasks[idx_[end]].priority == x.priority) ++end;
      const Nanos own = c_[p] + block_[end];
      Nanos r = own;
      while (true) {
        if (r > x.deadline) {
          if (all == nullptr) return false;
          met = false;
          break;
        }
        Nanos next = own;
        for (size_t q = 0; q < end; ++q) {
          if (q != p) next += (r + t_[q] - 1) / t_[q] * c_[q];
        }
        if (next == r) break;
        r = next;
      }
      if (all != nullptr) (*all)[idx_[p]] = r;
    }
    return met;
  }

  std::vector<size_t> idx_;
  std::vector<Nanos> c_, t_, block_;
};

template <typename F>
double best_seconds(int repeats, F f) {
  double best = 1e300;
  for (int k = 0; k < repeats; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    best = std::min(best,
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best;
}

int compare(size_t count) {
  const std::vector<TaskSet> sets = mixed_sets(count);
  std::string stream;
  std::vector<std::string> lines;
  for (const TaskSet& s : sets) {
    lines.push_back(contego::sched::to_json_line(s));
    stream += lines.back();
  }
  Analyzer analyzer;
  PlainRta plain;
  size_t feasible = 0;
  std::vector<Nanos> responses;
  for (const TaskSet& s : sets) {
    const bool a = analyzer.schedulable(s);
    const contego::sched::Analysis full = analyzer.analyse(s);
    bool same = a == plain.schedulable(s) && full.schedulable == a &&
                plain.response_times(s, responses) == a;
    // Every schedulable task's R_i is the same least fixed point.
    for (size_t i = 0; same && i < s.tasks.size(); ++i) {
      same = !full.tasks[i].schedulable || full.tasks[i].response == responses[i];
    }
    if (!same) {
      std::fprintf(stderr, "sched_bench: the library and the plain test disagree on a set\n");
      return 1;
    }
    feasible += a ? 1 : 0;
  }
  size_t sink = 0;
  const double t_plain = best_seconds(5, [&] {
    for (const TaskSet& s : sets) sink += plain.schedulable(s);
  });
  const double t_verdict = best_seconds(5, [&] {
    for (const TaskSet& s : sets) sink += analyzer.schedulable(s);
  });
  const double t_plain_all = best_seconds(5, [&] {
    for (const TaskSet& s : sets) sink += plain.response_times(s, responses);
  });
  // Like the plain test's vector of responses, the analysis is reused.
  contego::sched::Analysis reused;
  const double t_analyse = best_seconds(5, [&] {
    for (const TaskSet& s : sets) {
      analyzer.analyse(s, reused);
      sink += reused.schedulable;
    }
  });
  const double t_parse_analyse = best_seconds(3, [&] {
    for (const std::string& l : lines) {
      auto s = contego::sched::parse_json(l, "bench");
      sink += analyzer.analyse(contego::sched::resolve_overheads(*s, std::nullopt, 0)).schedulable;
    }
  });
  contego::sched::BatchOptions bo;
  bo.sensitivity = false;
  const double t_batch = best_seconds(3, [&] {
    std::istringstream in(stream);
    std::ostringstream out;
    sink += contego::sched::run_batch(in, "bench", bo, out, nullptr).sets;
  });
  const double t_sens = best_seconds(3, [&] {
    for (const TaskSet& s : sets) sink += contego::sched::sensitivity(s).tasks.size();
  });
  const size_t few = std::max<size_t>(1, count / 10);
  double t_search = 0, t_analyse_few = 0;
  t_search = best_seconds(1, [&] {
    for (size_t k = 0; k < few; ++k)
      sink += contego::sched::sensitivity_by_search(sets[k]).tasks.size();
  });
  t_analyse_few = best_seconds(5, [&] {
    for (size_t k = 0; k < few; ++k) {
      analyzer.analyse(sets[k], reused);
      sink += reused.schedulable;
    }
  });
  const double n = static_cast<double>(count);
  std::printf(
      "sched_bench comparison: %zu random sets of 5-50 tasks (%zu schedulable), C^o 50us, DM\n",
      count, feasible);
  std::printf("  plain response-time test (this file)  %9.2f us/set\n", t_plain / n * 1e6);
  std::printf(
      "  library, verdict only                  %9.2f us/set  %.2fx the plain test's speed, "
      "identical verdicts\n",
      t_verdict / n * 1e6, t_plain / t_verdict);
  std::printf("  plain test, every response time       %9.2f us/set\n", t_plain_all / n * 1e6);
  std::printf(
      "  library, full analysis                 %9.2f us/set  %.2fx the plain test's every "
      "response time, same R_i\n",
      t_analyse / n * 1e6, t_plain_all / t_analyse);
  std::printf("  library, JSON parse + analysis         %9.2f us/set\n", t_parse_analyse / n * 1e6);
  std::printf("  sched --batch stream (no sensitivity)  %9.2f us/set  %.2fx the library's time\n",
              t_batch / n * 1e6, t_batch / t_parse_analyse);
  std::printf("  sensitivity                            %9.2f us/set  %.1f analyses\n",
              t_sens / n * 1e6, t_sens / t_analyse);
  std::printf("  sensitivity by binary search (%zu sets) %9.2f us/set  %.1f analyses\n\n", few,
              t_search / static_cast<double>(few) * 1e6, t_search / t_analyse_few);
  benchmark::DoNotOptimize(sink);
  return 0;
}

// Full analysis: every task's response time, no early exit.
// Runs `run(analyzer, set)` over 64 random sets of state.range(0) tasks in turn.
template <typename Run>
void over_sets(benchmark::State& state, Run run) {
  const auto sets = make_sets(static_cast<size_t>(state.range(0)), 64);
  Analyzer analyzer;
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(run(analyzer, sets[k++ % sets.size()]));
  }
  state.counters["task_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Analyse(benchmark::State& state) {
  over_sets(state, [](Analyzer& a, const auto& set) { return a.analyse(set); });
}
BENCHMARK(BM_Analyse)->Arg(10)->Arg(50)->Arg(200);

// Verdict only (stops at the first miss), as the experiment uses it.
void BM_Schedulable(benchmark::State& state) {
  over_sets(state, [](Analyzer& a, const auto& set) { return a.schedulable(set); });
}
BENCHMARK(BM_Schedulable)->Arg(10)->Arg(50)->Arg(200);

// The sensitivity figures of a set (max C^o, min period, max N per task).
void BM_Sensitivity(benchmark::State& state) {
  const auto sets = make_sets(static_cast<size_t>(state.range(0)), 64);
  size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(contego::sched::sensitivity(sets[k++ % sets.size()]));
  }
  state.counters["task_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Sensitivity)->Arg(10)->Arg(50)->Arg(200);

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

int main(int argc, char** argv) {
  size_t compare_sets = 2000;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--compare-sets=", 15) == 0) {
      compare_sets = std::strtoul(argv[i] + 15, nullptr, 10);
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (compare_sets > 0 && compare(compare_sets) != 0) return 1;
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  if (benchmark::ReportUnrecognizedArguments(n, rest.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
