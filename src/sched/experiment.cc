#include "sched/experiment.h"

#include <cmath>
#include <cstdio>

#include "sched/analysis.h"

namespace contego::sched {
namespace {

int64_t point_count(const ExperimentOptions& o) {
  return static_cast<int64_t>(std::floor((o.u_max - o.u_min) / o.u_step + 1e-9)) + 1;
}

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

Status validate(const ExperimentOptions& o) {
  if (Status st = validate(o.generator); !st.ok()) return st;
  if (o.overheads.empty()) return make_error("at least one overhead is needed");
  for (Nanos c : o.overheads) {
    if (c < 0 || c > kMaxDuration) return make_error("overheads must be between 0 and 1000000s");
  }
  if (!(o.u_min > 0) || !(o.u_step > 0) || !(o.u_max >= o.u_min) ||
      o.u_max > static_cast<double>(o.generator.tasks)) {
    return make_error("utilisation range: need 0 < min <= max <= number of tasks and step > 0");
  }
  if (point_count(o) > 10'000) return make_error("utilisation range has too many points");
  if (o.sets_per_point < 1 || o.sets_per_point > 100'000'000) {
    return make_error("sets per point must be between 1 and 100000000");
  }
  if (o.assignment == Assignment::kGiven) {
    return make_error("generated sets have no priorities: use rm, dm or audsley");
  }
  return {};
}

ExperimentResult run_experiment(const ExperimentOptions& o) {
  Generator gen(o.seed);
  Analyzer analyzer;
  ExperimentResult out;
  const int64_t points = point_count(o);
  for (int64_t k = 0; k < points; ++k) {
    const double u = o.u_min + static_cast<double>(k) * o.u_step;
    const size_t first = out.rows.size();
    for (Nanos c : o.overheads) out.rows.push_back({u, c, 0, 0});
    for (int64_t s = 0; s < o.sets_per_point; ++s) {
      TaskSet set = gen.generate(o.generator, u);
      ++out.sets;
      // RM/DM orders do not depend on C^o: assign once per set.
      if (o.assignment != Assignment::kAudsley) set = assign_priorities(set, o.assignment).set;
      for (size_t j = 0; j < o.overheads.size(); ++j) {
        for (Task& t : set.tasks) t.overhead = o.overheads[j];
        const bool ok = o.assignment == Assignment::kAudsley
                            ? assign_priorities(set, o.assignment).found
                            : analyzer.schedulable(set);
        ExperimentRow& row = out.rows[first + j];
        ++row.sets;
        row.schedulable += ok ? 1 : 0;
        ++out.analyses;
      }
    }
  }
  // Overhead-major, so each curve is a contiguous run of rows in the CSV.
  std::vector<ExperimentRow> by_overhead;
  for (size_t j = 0; j < o.overheads.size(); ++j) {
    for (size_t k = j; k < out.rows.size(); k += o.overheads.size())
      by_overhead.push_back(out.rows[k]);
  }
  out.rows = std::move(by_overhead);
  return out;
}

std::string experiment_csv(const ExperimentResult& r) {
  std::string out = "utilisation,overhead_ns,overhead,sets,schedulable,ratio\n";
  for (const ExperimentRow& row : r.rows) {
    out += fixed(row.utilisation, 4) + "," + std::to_string(row.overhead) + "," +
           format_duration(row.overhead) + "," + std::to_string(row.sets) + "," +
           std::to_string(row.schedulable) + "," + fixed(row.ratio(), 6) + "\n";
  }
  return out;
}

std::string experiment_gnuplot(const ExperimentResult& r, const ExperimentOptions& o,
                               const std::string& csv_path, const std::string& svg_path,
                               const std::string& png_path) {
  (void)r;
  const GenOptions& g = o.generator;
  std::string title = std::to_string(g.tasks) + " tasks, periods " + format_duration(g.period_min) +
                      "-" + format_duration(g.period_max) + " log-uniform, " +
                      (g.constrained ? "constrained" : "implicit") + " deadlines, N " +
                      std::to_string(g.actuations_min) + "-" + std::to_string(g.actuations_max) +
                      " checks/job, " + assignment_name(o.assignment) + ", " +
                      std::to_string(o.sets_per_point) + " sets/point, seed " +
                      std::to_string(o.seed);
  std::string plot;
  for (size_t j = 0; j < o.overheads.size(); ++j) {
    if (!plot.empty()) plot += ", \\\n     ";
    plot += "'" + csv_path + "' using 1:($2 == " + std::to_string(o.overheads[j]) +
            " ? $6 : 1/0) with linespoints ls " + std::to_string(j % 8 + 1) +
            " title 'C^o = " + format_duration(o.overheads[j]) + "'";
  }
  std::string body =
      "set datafile separator ','\n"
      "set key autotitle columnhead\n"
      "set title \"Schedulability with checking overhead\\n{/*0.8 " +
      title +
      "}\"\n"
      "set xlabel 'utilisation without checking (sum C_i / T_i)'\n"
      "set ylabel 'schedulable task sets (fraction)'\n"
      "set xrange [0:" +
      fixed(o.u_max + o.u_step / 2, 3) +
      "]\n"
      "set yrange [0:1.05]\n"
      "set grid\n"
      "set key left bottom\n"
      "set style line 1 lc rgb '#1b9e77' lw 2 pt 7 ps 0.6\n"
      "set style line 2 lc rgb '#d95f02' lw 2 pt 5 ps 0.6\n"
      "set style line 3 lc rgb '#7570b3' lw 2 pt 9 ps 0.6\n"
      "set style line 4 lc rgb '#e7298a' lw 2 pt 11 ps 0.6\n"
      "set style line 5 lc rgb '#66a61e' lw 2 pt 13 ps 0.6\n"
      "set style line 6 lc rgb '#e6ab02' lw 2 pt 15 ps 0.6\n"
      "set style line 7 lc rgb '#a6761d' lw 2 pt 3 ps 0.6\n"
      "set style line 8 lc rgb '#666666' lw 2 pt 1 ps 0.6\n"
      "set style increment user\n";
  return body + "set terminal svg size 900,600 dynamic enhanced font 'Sans,12'\nset output '" +
         svg_path + "'\nplot " + plot +
         "\nset terminal pngcairo size 900,600 enhanced font 'Sans,11'\nset output '" + png_path +
         "'\nreplot\nunset output\n";
}

}  // namespace contego::sched
