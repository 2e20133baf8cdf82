// Google Benchmark of the schedulability analysis: task sets analysed per
// second for 10-, 50- and 200-task sets (random, UUniFast-discard at
// U = 0.7, log-uniform periods 10 ms - 1 s, N 1-5, C^o = 50 us, DM order),
// the sensitivity search, and `contego sched --batch`'s stream against the
// library's own parse + analyse.
//
// Before the benchmarks, a comparison over the same random sets in the same
// run (5-50 tasks, U 0.3-0.95; --compare-sets=N, default 2000), in thread
// CPU time, the median of interleaved rounds:
//   - the library against a textbook response-time test written below with
//     the paper's terms (C^TEE and blocking), by set size: the analysis as
//     `contego sched` prints it (analyse(), a new result per set), the
//     Analyzer into a reused result, and the verdict alone; verdicts and
//     every schedulable R_i must be identical, else the bench exits 1;
//   - the batch stream against parse + analyse of the same JSON lines;
//   - the sensitivity search (and the binary search it replaced) in units
//     of one analysis of the same sets.
// Build with the release preset for real figures:
//   cmake --build --preset release --target sched_bench && build/release/bench/sched_bench
#include <algorithm>
#include <benchmark/benchmark.h>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
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

// The textbook response-time test (Joseph and Pandya; the paper's appendix
// adds C^TEE and the blocking term), written as a reader new to the library
// would: one vector of the tasks by decreasing priority, and for each task
// R = C_i^TEE + B_i + sum over hp(i) of ceil(R / T_j) C_j^TEE from
// R = C_i^TEE until it repeats or exceeds D_i. Plain int64 nanoseconds (the
// bench's sets cannot overflow). With `response`, every task's R (the first
// iterate beyond D_i for a miss), the work of the library's analyse();
// without, it stops at the first miss, the work of Analyzer::schedulable().
bool textbook_rta(const TaskSet& set, std::vector<Nanos>* response) {
  struct Row {
    Nanos c, t, d, checking;  // C^TEE, T, D, N C^o
    int64_t priority;
    size_t index;
  };
  std::vector<Row> rows;
  rows.reserve(set.tasks.size());
  for (size_t i = 0; i < set.tasks.size(); ++i) {
    const Task& x = set.tasks[i];
    rows.push_back({x.wcet + x.actuations * x.overhead, x.period, x.deadline,
                    x.actuations * x.overhead, x.priority, i});
  }
  std::sort(rows.begin(), rows.end(),
            [](const Row& a, const Row& b) { return a.priority > b.priority; });
  const size_t n = rows.size();
  if (response != nullptr) response->assign(n, 0);
  bool ok = true;
  for (size_t i = 0; i < n; ++i) {
    Nanos b = 0;  // B_i: the largest N_j C_j^o of a strictly lower priority
    for (size_t j = i + 1; j < n; ++j) {
      if (rows[j].priority < rows[i].priority) b = std::max(b, rows[j].checking);
    }
    Nanos r = rows[i].c;
    while (true) {
      Nanos next = rows[i].c + b;
      // hp(i): every other task of the same or a higher priority.
      for (size_t j = 0; j < n && rows[j].priority >= rows[i].priority; ++j) {
        if (j != i) next += (r + rows[j].t - 1) / rows[j].t * rows[j].c;
      }
      if (next > rows[i].d) {
        r = next;
        ok = false;
        break;
      }
      if (next == r) break;
      r = next;
    }
    if (response != nullptr) {
      (*response)[rows[i].index] = r;
    } else if (!ok) {
      return false;
    }
  }
  return ok;
}

// Thread CPU time: on a shared machine, time the thread spent descheduled
// is not charged to whichever variant happened to be running.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Times each variant over the same sets, `repeats` rounds with the variants
// interleaved in each, and returns each variant's median round.
std::vector<double> interleaved(int repeats, const std::vector<std::function<void()>>& variants) {
  std::vector<std::vector<double>> rounds(variants.size());
  for (int k = 0; k < repeats; ++k) {
    for (size_t v = 0; v < variants.size(); ++v) {
      const double t0 = cpu_seconds();
      variants[v]();
      rounds[v].push_back(cpu_seconds() - t0);
    }
  }
  std::vector<double> out;
  for (auto& r : rounds) out.push_back(median(r));
  return out;
}

// The library and the textbook must agree on every verdict and on every
// schedulable task's R_i (the least fixed point; a miss's iterate depends
// on where the iteration starts).
bool same_results(const std::vector<TaskSet>& sets, size_t* feasible) {
  Analyzer analyzer;
  std::vector<Nanos> responses;
  *feasible = 0;
  for (const TaskSet& s : sets) {
    const bool verdict = textbook_rta(s, nullptr);
    const contego::sched::Analysis printed = contego::sched::analyse(s);
    bool same = textbook_rta(s, &responses) == verdict && printed.schedulable == verdict &&
                analyzer.schedulable(s) == verdict;
    for (size_t i = 0; same && i < s.tasks.size(); ++i) {
      same = printed.tasks[i].schedulable == (responses[i] <= s.tasks[i].deadline) &&
             (!printed.tasks[i].schedulable || printed.tasks[i].response == responses[i]);
    }
    if (!same) return false;
    *feasible += verdict ? 1 : 0;
  }
  return true;
}

int compare(size_t count) {
  const std::vector<TaskSet> sets = mixed_sets(count);
  size_t feasible = 0;
  if (!same_results(sets, &feasible)) {
    std::fprintf(stderr, "sched_bench: the library and the textbook test disagree on a set\n");
    return 1;
  }
  std::printf(
      "sched_bench comparison: %zu random sets of 5-50 tasks (%zu schedulable), C^o 50us, DM;\n"
      "verdicts and every schedulable R_i identical to the textbook test's; thread CPU time,\n"
      "median of 5 interleaved rounds\n",
      count, feasible);
  size_t sink = 0;
  Analyzer analyzer;
  contego::sched::Analysis reused;
  std::vector<Nanos> responses;
  // The full analysis by set size (the fixed per-set costs weigh most on
  // small sets), then over all sets.
  struct Range {
    size_t lo, hi;
  };
  for (const Range range : {Range{5, 10}, Range{11, 25}, Range{26, 50}, Range{5, 50}}) {
    std::vector<const TaskSet*> part;
    for (const TaskSet& s : sets) {
      if (s.tasks.size() >= range.lo && s.tasks.size() <= range.hi) part.push_back(&s);
    }
    const std::vector<double> t = interleaved(5, {[&] {
                                                    for (const TaskSet* s : part)
                                                      sink += textbook_rta(*s, &responses);
                                                  },
                                                  [&] {
                                                    for (const TaskSet* s : part)
                                                      sink +=
                                                          contego::sched::analyse(*s).schedulable;
                                                  },
                                                  [&] {
                                                    for (const TaskSet* s : part) {
                                                      analyzer.analyse(*s, reused);
                                                      sink += reused.schedulable;
                                                    }
                                                  },
                                                  [&] {
                                                    for (const TaskSet* s : part)
                                                      sink += textbook_rta(*s, nullptr);
                                                  },
                                                  [&] {
                                                    for (const TaskSet* s : part)
                                                      sink += analyzer.schedulable(*s);
                                                  }});
    const double n = static_cast<double>(part.size());
    std::printf("  %zu-%zu tasks (%zu sets)\n", range.lo, range.hi, part.size());
    std::printf("    textbook test, every R_i             %9.3f us/set\n", t[0] / n * 1e6);
    std::printf(
        "    library analyse() as printed          %9.3f us/set  %.2fx the textbook's speed\n",
        t[1] / n * 1e6, t[0] / t[1]);
    std::printf("    library Analyzer, reused result       %9.3f us/set  %.2fx\n", t[2] / n * 1e6,
                t[0] / t[2]);
    std::printf("    textbook test, verdict (first miss)   %9.3f us/set\n", t[3] / n * 1e6);
    std::printf("    library verdict only                  %9.3f us/set  %.2fx\n", t[4] / n * 1e6,
                t[3] / t[4]);
  }

  // The batch stream against the library's own parse + analysis (at most
  // 10,000 sets: parsing JSON costs ten analyses).
  const size_t streamed = std::min<size_t>(count, 10000);
  std::string stream;
  std::vector<std::string> lines;
  for (size_t k = 0; k < streamed; ++k) {
    lines.push_back(contego::sched::to_json_line(sets[k]));
    stream += lines.back();
  }
  contego::sched::BatchOptions bo;
  bo.sensitivity = false;
  const std::vector<double> tb = interleaved(
      3, {[&] {
            for (const std::string& l : lines) {
              auto s = contego::sched::parse_json(l, "bench");
              analyzer.analyse(contego::sched::resolve_overheads(*s, std::nullopt, 0), reused);
              sink += reused.schedulable;
            }
          },
          [&] {
            std::istringstream in(stream);
            std::ostringstream out;
            sink += contego::sched::run_batch(in, "bench", bo, out, nullptr).sets;
          }});
  const double n = static_cast<double>(streamed);
  std::printf("  library, JSON parse + analysis (%zu sets) %9.2f us/set\n", streamed,
              tb[0] / n * 1e6);
  std::printf("  sched --batch stream (no sensitivity)   %9.2f us/set  %.2fx the library's time\n",
              tb[1] / n * 1e6, tb[1] / tb[0]);

  // Sensitivity in units of one analysis of the same sets (at most 5,000),
  // and the binary search it replaced (a tenth of those, at most 200).
  const size_t some = std::min<size_t>(count, 5000);
  const size_t few = std::clamp<size_t>(some / 10, 1, 200);
  const std::vector<double> ts =
      interleaved(3, {[&] {
                        for (size_t k = 0; k < some; ++k) {
                          analyzer.analyse(sets[k], reused);
                          sink += reused.schedulable;
                        }
                      },
                      [&] {
                        for (size_t k = 0; k < some; ++k)
                          sink += contego::sched::sensitivity(sets[k]).tasks.size();
                      },
                      [&] {
                        for (size_t k = 0; k < few; ++k) {
                          analyzer.analyse(sets[k], reused);
                          sink += reused.schedulable;
                        }
                      }});
  const double t_search =
      interleaved(1, {[&] {
                    for (size_t k = 0; k < few; ++k)
                      sink += contego::sched::sensitivity_by_search(sets[k]).tasks.size();
                  }})[0];
  std::printf("  sensitivity (%zu sets)                 %9.2f us/set  %.1f analyses\n", some,
              ts[1] / static_cast<double>(some) * 1e6, ts[1] / ts[0]);
  std::printf("  sensitivity by binary search (%zu sets)  %9.2f us/set  %.1f analyses\n\n", few,
              t_search / static_cast<double>(few) * 1e6, t_search / ts[2]);
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
