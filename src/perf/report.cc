// The bench's report: the table, bench.json, the overhead file for
// `contego sched --overhead-from` and the gnuplot chart (see overhead.h).
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fmt/core.h>
#include <fstream>
#include <sys/utsname.h>

#include "perf/overhead.h"
#include "perf/rig.h"

namespace contego::perf {

std::string table(const Report& r) {
  std::string s = fmt::format(
      "contego bench: {} trials per cell, CLOCK_MONOTONIC around each write() in the task\n"
      "checker: {}\n{}\n",
      r.trials, r.checker, detail::pinning_line(r.cpu));
  s += fmt::format("{:<30} {:<20} {:>9} {:>9} {:>9} {:>10}   {:>9} {:>9} {:>9}   {}\n", "task",
                   "path", "mean", "median", "p99", "worst", "+median", "+p99", "+worst",
                   "decisions (audit log)");
  s += fmt::format("{:<30} {:<20} {:>9} {:>9} {:>9} {:>10}   {:>9} {:>9} {:>9}\n", "", "", "µs",
                   "µs", "µs", "µs", "µs", "µs", "µs");
  for (const Row& row : r.rows) {
    const Row* base = r.find(row.workload, Path::kUnprotected);
    const Stats& b = base != nullptr ? base->stats : row.stats;
    const Stats& x = row.stats;
    s += fmt::format("{:<30} {:<20} {:>9.2f} {:>9.2f} {:>9.2f} {:>10.2f}", row.workload,
                     path_label(row.path), x.mean_us, x.median_us, x.p99_us, x.worst_us);
    if (row.path == Path::kUnprotected) {
      s += "   (baseline, not checked)";
    } else {
      s += fmt::format("   {:>9.2f} {:>9.2f} {:>9.2f}  ", x.median_us - b.median_us,
                       x.p99_us - b.p99_us, x.worst_us - b.worst_us);
      for (const auto& [decision, count] : row.decisions) {
        s += fmt::format(" {} {}", decision, count);
      }
    }
    if (row.failures != 0) s += "  (some commands failed)";
    s += "\n";
  }
  // The headline: rows whose every command was allowed (a row of ignored
  // or refused commands times another path through the checker).
  s += "\nadded µs per allowed command vs a (mean / median / p99 / p99.9 / worst):";
  std::string excluded;
  for (const Row& row : r.rows) {
    const Row* base = r.find(row.workload, Path::kUnprotected);
    if (row.path == Path::kUnprotected || base == nullptr) continue;
    if (!row.all_allowed()) {
      excluded += fmt::format("\n  {:<30} {:<20}", row.workload, path_label(row.path));
      for (const auto& [decision, count] : row.decisions) {
        excluded += fmt::format(" {} {}", decision, count);
      }
      continue;
    }
    const Stats& x = row.stats;
    const Stats& b = base->stats;
    s += fmt::format("\n  {:<30} {:<20} {:>8.2f} {:>8.2f} {:>8.2f} {:>8.2f} {:>9.2f}", row.workload,
                     path_label(row.path), x.mean_us - b.mean_us, x.median_us - b.median_us,
                     x.p99_us - b.p99_us, x.p999_us - b.p999_us, x.worst_us - b.worst_us);
  }
  if (!excluded.empty()) s += "\nnot in the headline (not every command allowed):" + excluded;
  s += "\n";
  for (const DosResult& d : r.dos) {
    if (!d.skipped.empty()) {
      s += fmt::format("\nDoS ({}): not measured: {}", d.transport, d.skipped);
      continue;
    }
    s += fmt::format(
        "\nDoS: follower every {} µs through the monitor process ({}); p99 {:.2f} µs alone, "
        "{:.2f} µs while another supervised task bursts ({} commands sent); worst {:.2f} / "
        "{:.2f} µs",
        d.period_us, d.transport, d.quiet.p99_us, d.under_burst.p99_us, d.burst_commands,
        d.quiet.worst_us, d.under_burst.worst_us);
  }
  if (!r.dos.empty()) s += "\n";
  return s;
}

namespace {
nlohmann::json stats_json(const Stats& s) {
  return {{"n", s.n},           {"mean_us", s.mean_us}, {"median_us", s.median_us},
          {"p99_us", s.p99_us}, {"p999_us", s.p999_us}, {"worst_us", s.worst_us}};
}

std::string machine() {
  utsname u{};
  uname(&u);
  return fmt::format("{} {} {} ({} CPUs online)", u.nodename, u.sysname, u.release,
                     sysconf(_SC_NPROCESSORS_ONLN));
}
}  // namespace

nlohmann::json to_json(const Report& r) {
  nlohmann::json j;
  j["trials"] = r.trials;
  j["checker"] = r.checker;
  if (r.cpu >= 0) j["task_cpu"] = r.cpu;
  j["measured_on"] = machine();
  for (const Row& row : r.rows) {
    nlohmann::json cell = stats_json(row.stats);
    const Row* base = r.find(row.workload, Path::kUnprotected);
    if (base != nullptr && row.path != Path::kUnprotected) {
      cell["added_mean_us"] = row.stats.mean_us - base->stats.mean_us;
      cell["added_median_us"] = row.stats.median_us - base->stats.median_us;
      cell["added_p99_us"] = row.stats.p99_us - base->stats.p99_us;
      cell["added_p999_us"] = row.stats.p999_us - base->stats.p999_us;
      cell["all_allowed"] = row.all_allowed();
      cell["added_worst_us"] = row.stats.worst_us - base->stats.worst_us;
    }
    cell["failures"] = row.failures;
    cell["decisions"] = row.decisions;
    j["workloads"][row.workload][path_key(row.path)] = cell;
  }
  for (const DosResult& d : r.dos) {
    if (!d.skipped.empty()) {
      j["dos"][d.transport] = {{"skipped", d.skipped}};
      continue;
    }
    j["dos"][d.transport] = {{"period_us", d.period_us},
                             {"quiet", stats_json(d.quiet)},
                             {"under_burst", stats_json(d.under_burst)},
                             {"burst_commands", d.burst_commands}};
  }
  j["sched_overhead"] = sched_overhead(r);
  return j;
}

nlohmann::json sched_overhead(const Report& r) {
  bool any_allowed = false;
  for (const Row& row : r.rows)
    any_allowed = any_allowed || (row.path == Path::kSeccompMonitor && row.all_allowed());
  struct Figure {
    const char* name;
    double Stats::*field;
  };
  const Figure figures[] = {{"median", &Stats::median_us},
                            {"p99", &Stats::p99_us},
                            {"p999", &Stats::p999_us},
                            {"max", &Stats::worst_us}};
  nlohmann::json stats = nlohmann::json::object();
  for (const Figure& f : figures) {
    double added = 0;
    for (const Row& row : r.rows) {
      const Row* base = r.find(row.workload, Path::kUnprotected);
      if (row.path != Path::kSeccompMonitor || base == nullptr) continue;
      if (any_allowed && !row.all_allowed()) continue;
      added = std::max(added, row.stats.*f.field - base->stats.*f.field);
    }
    stats[f.name] = static_cast<int64_t>(added * 1000.0 + 0.5);
  }
  return {
      {"overhead_ns", stats["p999"]},
      {"statistic", "p999"},
      {"statistics_ns", stats},
      {"measured_on", machine()},
      {"method", fmt::format("contego bench: largest added figure (c2 minus a) over {} trials of "
                             "the seccomp client with a separate monitor process, {} ({})",
                             r.trials,
                             any_allowed ? "rows whose commands were all allowed"
                                         : "all rows (none had every command allowed)",
                             r.checker)}};
}

Status write_chart(const Report& r, const std::string& stem) {
  const std::string dat = stem + ".dat", gp = stem + ".gp";
  // One data block per workload (gnuplot `index`), one row per path.
  std::vector<std::string> workloads;
  for (const Row& row : r.rows) {
    if (std::find(workloads.begin(), workloads.end(), row.workload) == workloads.end()) {
      workloads.push_back(row.workload);
    }
  }
  {
    std::ofstream d(dat);
    d << "# path mean_us p99_us worst_us; one block per workload\n";
    for (const std::string& w : workloads) {
      d << "# " << w << "\n";
      for (const Row& row : r.rows) {
        if (row.workload != w) continue;
        d << fmt::format("\"{}\" {:.3f} {:.3f} {:.3f}\n", path_label(row.path), row.stats.mean_us,
                         row.stats.p99_us, row.stats.worst_us);
      }
      d << "\n\n";
    }
    if (!d) return make_error("cannot write " + dat);
  }
  std::ofstream g(gp);
  const auto plot = [&](const std::string& term, const std::string& out) {
    g << "set terminal " << term << "\n"
      << "set output '" << out << "'\n"
      << "set title 'contego: time per actuation command (" << r.trials
      << " trials per bar; a = unprotected transfer)'\n"
      << "set ylabel 'microseconds (log scale)'\n"
      << "set logscale y\n"
      << "set yrange [0.01:*]\n"  // also where each group's title goes
      << "set grid ytics\n"
      << "set style data histograms\n"
      << "set style histogram clustered gap 1\n"
      << "set style fill solid 0.85 border -1\n"
      << "set boxwidth 0.9\n"
      << "set xtics rotate by -45 font ',8' nomirror\n"
      << "set bmargin 10\n"
      << "set key top left horizontal\n"
      << "plot ";
    for (size_t i = 0; i < workloads.size(); ++i) {
      const bool first = i == 0;
      if (!first) g << ", \\\n  ";
      g << "newhistogram '" << workloads[i] << "', '" << dat << "' index " << i
        << " using 2:xtic(1) " << (first ? "title 'mean'" : "notitle")
        << " lc rgb '#4c72b0', '' index " << i << " using 3 "
        << (first ? "title '99th percentile'" : "notitle") << " lc rgb '#dd8452', '' index " << i
        << " using 4 " << (first ? "title 'worst case'" : "notitle") << " lc rgb '#c44e52'";
    }
    g << "\n";
  };
  plot("svg size 1400,640 dynamic", stem + ".svg");
  plot("pngcairo size 1400,640", stem + ".png");
  g.close();
  if (!g) return make_error("cannot write " + gp);
  const int rc = system(("gnuplot '" + gp + "' 2>&1").c_str());
  if (rc != 0) return make_error("gnuplot failed on " + gp);
  return {};
}

}  // namespace contego::perf
