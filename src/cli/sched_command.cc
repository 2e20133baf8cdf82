// `contego sched`: design-time schedulability with checking overhead.
//
//   contego sched TASKSET [--overhead D | --overhead-from FILE [--stat S]] [--assign A] [--json]
//   contego sched --batch [STREAM|-] ...   (sched/batch.h: one JSON line per set)
//   contego sched experiment ...   (see sched_experiment below)
//
// Exit status: 0 schedulable, 1 some task can miss its deadline, 2 bad input
// (--batch: 2 if any set was bad input, else 1 if any set can miss).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <fmt/core.h>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/clock.h"
#include "cli/command.h"
#include "sched/analysis.h"
#include "sched/assign.h"
#include "sched/batch.h"
#include "sched/duration.h"
#include "sched/experiment.h"
#include "sched/reader.h"
#include "sched/sensitivity.h"

#ifdef CONTEGO_HAVE_POLICY
#include "base/json_text.h"
#include "cli/sched_closure.h"
#include "policy/compile.h"
#endif

namespace contego::cli {
namespace {

constexpr int kExitUnschedulable = 1;
constexpr int kExitBadInput = 2;

struct SchedArgs {
  std::string input;
  std::string overhead;
  std::string overhead_from;
  std::string stat;
  std::string assign;
  bool json = false;
  bool no_sensitivity = false;
  bool batch = false;
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void fail(const std::string& message) {
  fmt::print(stderr, "contego sched: {}\n", message);
  set_exit_code(kExitBadInput);
}

std::string figure(int64_t v, bool duration) {
  if (v == sched::kUnbounded) return "unbounded";
  if (v == sched::kInfeasible) return "none";
  return duration ? sched::format_duration(v) : std::to_string(v);
}

nlohmann::json json_figure(int64_t v) {
  if (v == sched::kUnbounded) return "unbounded";
  if (v == sched::kInfeasible) return "infeasible";
  return v;
}

// A task-set file, or a policy whose task model the compiler extracts.
Result<sched::TaskSet> read_input(const std::string& path) {
  if (!ends_with(path, ".policy")) return sched::read_task_set_file(path);
#ifdef CONTEGO_HAVE_POLICY
  const policy::CompileOutput out = policy::compile_file(path);
  if (!out.ok) {
    std::string text = path + ": the policy does not compile:";
    for (const policy::Diagnostic& d : out.diagnostics) {
      if (d.severity == "error") text += "\n" + d.rendered;
    }
    return make_error(text);
  }
  sched::TaskSet set = tasks_from_image(out.model);
  if (Status st = sched::validate(set); !st.ok()) return make_error(path + ": " + st.error());
  return set;
#else
  return make_error(path +
                    ": reading the task model from a policy needs the policy compiler, which "
                    "this build lacks; give the tasks as CSV or JSON (docs/sched.md)");
#endif
}

// C^o forced by a flag: --overhead, or a statistic of a measured file.
struct ForcedOverhead {
  std::optional<sched::Nanos> value;
  std::string source;                 // for the report
  std::string statistic;              // --overhead-from: which one
  std::optional<sched::Nanos> worst;  // --overhead-from: the file's max, shown beside
};

Result<ForcedOverhead> forced_overhead(const SchedArgs& args) {
  ForcedOverhead f;
  if (!args.overhead.empty()) {
    Result<sched::Nanos> d = sched::parse_duration(args.overhead);
    if (!d) return make_error("--overhead: " + d.error());
    f.value = *d;
    f.source = "--overhead";
  } else if (!args.overhead_from.empty()) {
    Result<sched::MeasuredOverhead> m = sched::read_overhead_file(args.overhead_from);
    if (!m) return make_error("--overhead-from: " + m.error());
    Result<sched::ChosenOverhead> c = sched::choose_overhead(*m, args.stat, args.overhead_from);
    if (!c) return make_error("--stat: " + c.error());
    f.value = c->overhead;
    f.statistic = c->statistic;
    f.worst = c->worst;
    f.source = "measured " + c->statistic +
               (c->worst ? " (worst " + sched::format_duration(*c->worst) + ")" : "") + " of " +
               args.overhead_from + (m->measured_on.empty() ? "" : ", on " + m->measured_on) +
               (m->method.empty() ? "" : ", " + m->method);
  } else if (!args.stat.empty()) {
    return make_error("--stat chooses a statistic of --overhead-from FILE; give the file");
  }
  return f;
}

void run_batch(const SchedArgs& args) {
  Result<ForcedOverhead> forced = forced_overhead(args);
  if (!forced) return fail(forced.error());
  sched::BatchOptions o;
  o.overhead = forced->value;
  o.sensitivity = !args.no_sensitivity;
  if (!args.assign.empty()) {
    Result<sched::Assignment> how = sched::parse_assignment(args.assign);
    if (!how) return fail("--assign: " + how.error());
    o.assign = *how;
  }
  const bool from_stdin = args.input.empty() || args.input == "-";
  std::ifstream file;
  if (!from_stdin) {
    file.open(args.input);
    if (!file) return fail(args.input + ": cannot open");
  }
  std::ios::sync_with_stdio(false);
  const sched::BatchSummary s = sched::run_batch(
      from_stdin ? std::cin : file, from_stdin ? "<stdin>" : args.input, o, std::cout, &std::cerr);
  std::cout.flush();
  fmt::print(stderr, "contego sched --batch: {} task sets, {} unschedulable, {} bad\n", s.sets,
             s.unschedulable, s.failed);
  set_exit_code(s.failed > 0 ? kExitBadInput : s.unschedulable > 0 ? kExitUnschedulable : 0);
}

void run_sched(const SchedArgs& args) {
  Result<sched::TaskSet> read = read_input(args.input);
  if (!read) return fail(read.error());
  sched::TaskSet set = std::move(*read);

  // Where C^o comes from: the flag, a measured file, the input, or nowhere.
  Result<ForcedOverhead> forced_or = forced_overhead(args);
  if (!forced_or) return fail(forced_or.error());
  const ForcedOverhead& measured = *forced_or;
  const std::optional<sched::Nanos> forced = measured.value;
  std::string source = forced ? measured.source : "input";
  if (!forced) {
    bool declared = set.overhead.has_value();
    for (const sched::Task& t : set.tasks)
      declared = declared || t.overhead != sched::kOverheadUnset;
    if (!declared) {
      source = "none";
      fmt::print(stderr,
                 "contego sched: warning: no checking overhead given (--overhead, "
                 "--overhead-from or the input's overhead); analysing with C^o = 0\n");
    }
  }
  set = sched::resolve_overheads(std::move(set), forced, 0);

  std::string how_text = args.assign;
  if (how_text.empty()) how_text = set.priorities_given ? "given" : "";
  if (how_text.empty()) {
    return fail(args.input + ": the tasks carry no priorities; choose --assign rm, dm or audsley");
  }
  Result<sched::Assignment> how = sched::parse_assignment(how_text);
  if (!how) return fail("--assign: " + how.error());
  if (*how == sched::Assignment::kGiven && !set.priorities_given) {
    return fail(args.input + ": --assign given, but the tasks carry no priorities");
  }
  const sched::Assigned assigned = sched::assign_priorities(set, *how);
  set = assigned.set;

  const sched::Analysis a = sched::analyse(set);
  std::optional<sched::Sensitivity> sens;
  if (!args.no_sensitivity) sens = sched::sensitivity(set);
  set_exit_code(a.schedulable ? 0 : kExitUnschedulable);

  if (args.json) {
    nlohmann::json out;
    out["source"] = args.input;
    out["assignment"] = sched::assignment_name(*how);
    if (*how == sched::Assignment::kAudsley) out["audsley_found_order"] = assigned.found;
    out["overhead_source"] = source;
    if (!measured.statistic.empty()) out["overhead_statistic"] = measured.statistic;
    if (measured.worst) out["overhead_worst_ns"] = *measured.worst;
    out["schedulable"] = a.schedulable;
    out["utilisation"] = sched::utilisation(set);
    out["utilisation_with_checking"] = sched::utilisation_with_checking(set);
    out["tasks"] = nlohmann::json::array();
    for (size_t i = 0; i < set.tasks.size(); ++i) {
      const sched::Task& t = set.tasks[i];
      const sched::TaskResult& r = a.tasks[i];
      nlohmann::json jt = {{"name", t.name},
                           {"priority", t.priority},
                           {"wcet_ns", t.wcet},
                           {"period_ns", t.period},
                           {"deadline_ns", t.deadline},
                           {"actuations", t.actuations},
                           {"overhead_ns", t.overhead},
                           {"c_tee_ns", r.c_tee},
                           {"blocking_ns", r.blocking},
                           {"iterations", r.iterations},
                           {"schedulable", r.schedulable}};
      if (r.schedulable) {
        jt["response_ns"] = r.response;
        jt["slack_ns"] = r.slack();
      } else {
        // The iteration stopped: the true response time exceeds this bound.
        jt["response_ns"] = nullptr;
        jt["response_exceeds_ns"] = r.response;
        jt["slack_ns"] = nullptr;
      }
      if (sens) {
        const sched::TaskSensitivity& s = sens->tasks[i];
        jt["max_overhead_ns"] = json_figure(s.max_overhead);
        jt["min_period_ns"] = json_figure(s.min_period);
        jt["max_actuations"] = json_figure(s.max_actuations);
      }
      out["tasks"].push_back(std::move(jt));
    }
    if (sens) out["max_overhead_ns"] = json_figure(sens->max_overhead);
    fmt::print("{}\n", json_text(out, 2));
    return;
  }

  fmt::print("{}: {} tasks, priorities {}, C^o from {}\n", args.input, set.tasks.size(),
             sched::assignment_name(*how), source);
  fmt::print("utilisation {:.3f} without checking, {:.3f} with checking\n\n",
             sched::utilisation(set), sched::utilisation_with_checking(set));
  size_t name_width = 4;
  for (const sched::Task& t : set.tasks) name_width = std::max(name_width, t.name.size());
  fmt::print("{:<{}} {:>5} {:>9} {:>9} {:>9} {:>4} {:>9} {:>9} {:>9} {:>10} {:>10}  {}\n", "task",
             name_width, "prio", "C", "T", "D", "N", "C^o", "C^TEE", "B", "R^TEE", "slack",
             "verdict");
  for (size_t i = 0; i < set.tasks.size(); ++i) {
    const sched::Task& t = set.tasks[i];
    const sched::TaskResult& r = a.tasks[i];
    const std::string resp = r.schedulable ? sched::format_duration(r.response)
                                           : "> " + sched::format_duration(t.deadline);
    const std::string slack = r.schedulable ? sched::format_duration(r.slack()) : "-";
    fmt::print("{:<{}} {:>5} {:>9} {:>9} {:>9} {:>4} {:>9} {:>9} {:>9} {:>10} {:>10}  {}\n", t.name,
               name_width, t.priority, sched::format_duration(t.wcet),
               sched::format_duration(t.period), sched::format_duration(t.deadline), t.actuations,
               sched::format_duration(t.overhead), sched::format_duration(r.c_tee),
               sched::format_duration(r.blocking), resp, slack,
               r.schedulable ? "ok" : "MISS (iterate " + sched::format_duration(r.response) + ")");
  }
  fmt::print("\n{}\n", a.schedulable ? "schedulable: every task meets its deadline"
                                     : "NOT schedulable: some task can miss its deadline");
  if (*how == sched::Assignment::kAudsley && !assigned.found) {
    fmt::print("Audsley: no priority order makes this set schedulable\n");
  }
  if (!sens) return;
  fmt::print("\nsensitivity (exact boundaries of the test):\n");
  if (sens->max_overhead == sched::kInfeasible) {
    fmt::print("  the set misses a deadline even with free checking (C^o = 0)\n");
  } else if (sens->max_overhead == sched::kUnbounded) {
    fmt::print("  no task has checked commands: the checking cost cannot cause a miss\n");
  } else {
    fmt::print("  checking may cost up to {} per command before any deadline is missed\n",
               sched::format_duration(sens->max_overhead));
  }
  fmt::print("  {:<{}} {:>14} {:>12} {:>8}\n", "task", name_width, "tolerates C^o", "min period",
             "max N");
  for (size_t i = 0; i < set.tasks.size(); ++i) {
    const sched::TaskSensitivity& s = sens->tasks[i];
    fmt::print("  {:<{}} {:>14} {:>12} {:>8}\n", set.tasks[i].name, name_width,
               figure(s.max_overhead, true), figure(s.min_period, true),
               figure(s.max_actuations, false));
  }
  fmt::print(
      "  (tolerates C^o: the largest uniform C^o at which that task still meets its deadline; min "
      "period and "
      "max N: the others unchanged, whole set still schedulable)\n");
}

struct ExperimentArgs {
  int64_t tasks = 20;
  int64_t sets = 5000;
  std::string utilisation = "0.05:1:0.05";
  std::string overheads = "0,50us,100us,200us,500us";
  std::string periods = "10ms:1s";
  std::string actuations = "1:5";
  std::string deadlines = "implicit";
  std::string assign = "dm";
  uint64_t seed = 1;
  std::string out = "sched_experiment";
  bool no_plot = false;
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  size_t start = 0;
  while (true) {
    const size_t at = s.find(sep, start);
    out.push_back(s.substr(start, at - start));
    if (at == std::string::npos) return out;
    start = at + 1;
  }
}

Result<double> parse_number(const std::string& s, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size()) {
    return make_error(what + ": '" + s + "' is not a number");
  }
  return v;
}

Status parse_experiment(const ExperimentArgs& a, sched::ExperimentOptions* o) {
  if (a.tasks < 1 || a.tasks > 10000) return make_error("--tasks must be between 1 and 10000");
  o->generator.tasks = static_cast<size_t>(a.tasks);
  o->sets_per_point = a.sets;
  o->seed = a.seed;
  const std::vector<std::string> u = split(a.utilisation, ':');
  if (u.size() != 3) return make_error("--utilisation: expected MIN:MAX:STEP, e.g. 0.05:1:0.05");
  double* slots[] = {&o->u_min, &o->u_max, &o->u_step};
  for (size_t k = 0; k < 3; ++k) {
    Result<double> v = parse_number(u[k], "--utilisation");
    if (!v) return make_error(v.error());
    *slots[k] = *v;
  }
  o->overheads.clear();
  for (const std::string& part : split(a.overheads, ',')) {
    Result<sched::Nanos> d = sched::parse_duration(part);
    if (!d) return make_error("--overheads: " + d.error());
    o->overheads.push_back(*d);
  }
  const std::vector<std::string> p = split(a.periods, ':');
  if (p.size() != 2) return make_error("--periods: expected MIN:MAX, e.g. 10ms:1s");
  Result<sched::Nanos> pmin = sched::parse_duration(p[0]);
  Result<sched::Nanos> pmax = sched::parse_duration(p[1]);
  if (!pmin) return make_error("--periods: " + pmin.error());
  if (!pmax) return make_error("--periods: " + pmax.error());
  o->generator.period_min = *pmin;
  o->generator.period_max = *pmax;
  o->generator.period_granularity =
      std::min(sched::kNanosPerMicro, std::max<sched::Nanos>(*pmin, 1));
  const std::vector<std::string> n = split(a.actuations, ':');
  if (n.size() != 2) return make_error("--actuations: expected MIN:MAX, e.g. 1:5");
  for (size_t k = 0; k < 2; ++k) {
    Result<double> v = parse_number(n[k], "--actuations");
    if (!v || *v != std::floor(*v)) return make_error("--actuations: expected whole numbers");
    (k == 0 ? o->generator.actuations_min : o->generator.actuations_max) = static_cast<int64_t>(*v);
  }
  if (a.deadlines != "implicit" && a.deadlines != "constrained") {
    return make_error("--deadlines: expected implicit or constrained");
  }
  o->generator.constrained = a.deadlines == "constrained";
  Result<sched::Assignment> how = sched::parse_assignment(a.assign);
  if (!how) return make_error("--assign: " + how.error());
  o->assignment = *how;
  return sched::validate(*o);
}

Status write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  f.close();
  if (!f) return make_error(path + ": cannot write");
  return {};
}

void run_experiment(const ExperimentArgs& args) {
  sched::ExperimentOptions o;
  if (Status st = parse_experiment(args, &o); !st.ok()) {
    fmt::print(stderr, "contego sched experiment: {}\n", st.error());
    set_exit_code(kExitBadInput);
    return;
  }
  const uint64_t start_us = monotonic_us();
  const sched::ExperimentResult r = sched::run_experiment(o);
  const double seconds = static_cast<double>(monotonic_us() - start_us) * 1e-6;
  const std::string csv = args.out + ".csv";
  const std::string gp = args.out + ".gp";
  const std::string svg = args.out + ".svg";
  const std::string png = args.out + ".png";
  for (const auto& [path, text] : {std::pair{csv, sched::experiment_csv(r)},
                                   std::pair{gp, sched::experiment_gnuplot(r, o, csv, svg, png)}}) {
    if (Status st = write_file(path, text); !st.ok()) {
      fmt::print(stderr, "contego sched experiment: {}\n", st.error());
      set_exit_code(kExitBadInput);
      return;
    }
  }
  fmt::print("generated {} task sets of {} tasks, {} analyses in {:.2f} s ({:.0f} task sets/s)\n",
             r.sets, o.generator.tasks, r.analyses, seconds,
             seconds > 0 ? static_cast<double>(r.analyses) / seconds : 0.0);
  fmt::print("wrote {} and {}\n", csv, gp);
  // Utilisation at which each curve drops below 50 %: the headline number.
  for (sched::Nanos c : o.overheads) {
    double last_ok = 0;
    for (const sched::ExperimentRow& row : r.rows) {
      if (row.overhead == c && row.ratio() >= 0.5) last_ok = std::max(last_ok, row.utilisation);
    }
    fmt::print("  C^o = {:>8}: at least half the sets schedulable up to U = {:.2f}\n",
               sched::format_duration(c), last_ok);
  }
  if (args.no_plot) return;
  const std::string cmd = "gnuplot '" + gp + "'";
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    fmt::print(stderr, "contego sched experiment: gnuplot not found; run `{}` later\n", cmd);
    return;
  }
  if (std::system(cmd.c_str()) != 0) {
    fmt::print(stderr, "contego sched experiment: `{}` failed\n", cmd);
    set_exit_code(kExitBadInput);
    return;
  }
  fmt::print("wrote {} and {}\n", svg, png);
}

}  // namespace

void register_sched(CLI::App& app) {
  auto args = std::make_shared<SchedArgs>();
  auto* cmd = app.add_subcommand(
      "sched", "Schedulability with checking overhead (response-time analysis, sensitivity)");
  cmd->add_option("taskset", args->input, "Task set: CSV or JSON (docs/sched.md), or a policy");
  auto* over = cmd->add_option("--overhead", args->overhead,
                               "Per-command checking cost C^o for every task, e.g. 40us");
  cmd->add_option("--overhead-from", args->overhead_from,
                  "JSON file with the measured C^o written by `contego bench`")
      ->excludes(over);
  cmd->add_option("--stat", args->stat,
                  "Which statistic of --overhead-from: median, p99, p999 (default) or max");
  cmd->add_flag("--batch", args->batch,
                "A stream of task sets (JSON lines, CSV blocks; TASKSET or - for stdin), one "
                "JSON result line each");
  cmd->add_option("--assign", args->assign, "Priorities: given (default), rm, dm or audsley");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_flag("--no-sensitivity", args->no_sensitivity, "Skip the sensitivity analysis");
  cmd->require_subcommand(0, 1);

  auto ex = std::make_shared<ExperimentArgs>();
  auto* exp = cmd->add_subcommand(
      "experiment", "Schedulability ratio of random task sets against utilisation, per C^o");
  exp->option_defaults()->always_capture_default();  // every option shows its default
  exp->add_option("--tasks", ex->tasks, "Tasks per set");
  exp->add_option("--sets", ex->sets, "Task sets per utilisation point");
  exp->add_option("--utilisation", ex->utilisation, "MIN:MAX:STEP (checking-free utilisation)");
  exp->add_option("--overheads", ex->overheads, "Comma-separated C^o values, one curve each");
  exp->add_option("--periods", ex->periods, "MIN:MAX, log-uniform");
  exp->add_option("--actuations", ex->actuations, "MIN:MAX checked commands per job, uniform");
  exp->add_option("--deadlines", ex->deadlines, "implicit (D = T) or constrained (D in [C, T])");
  exp->add_option("--assign", ex->assign, "Priority assignment: rm, dm or audsley");
  exp->add_option("--seed", ex->seed, "Random seed");
  exp->add_option("--out", ex->out, "Output prefix: PREFIX.csv, .gp, .svg, .png");
  exp->add_flag("--no-plot", ex->no_plot, "Write CSV and gnuplot script, do not run gnuplot");
  exp->callback([ex] { run_experiment(*ex); });

  // The task-set positional is required unless the experiment runs.
  cmd->callback([args, exp] {
    if (exp->parsed()) return;
    if (args->batch) return run_batch(*args);
    if (args->input.empty()) {
      fail("a task-set file is required (or use `contego sched experiment`)");
      return;
    }
    run_sched(*args);
  });
}

}  // namespace contego::cli
