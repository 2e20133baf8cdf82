// `contego sched`: design-time schedulability with checking overhead.
//
//   contego sched TASKSET [--overhead D | --overhead-from FILE] [--assign A] [--json]
//   contego sched experiment ...   (see sched_experiment below)
//
// Exit status: 0 schedulable, 1 some task can miss its deadline, 2 bad input.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "cli/command.h"
#include "sched/analysis.h"
#include "sched/assign.h"
#include "sched/duration.h"
#include "sched/reader.h"
#include "sched/sensitivity.h"

namespace contego::cli {
namespace {

constexpr int kExitUnschedulable = 1;
constexpr int kExitBadInput = 2;

struct SchedArgs {
  std::string input;
  std::string overhead;
  std::string overhead_from;
  std::string assign;
  bool json = false;
  bool no_sensitivity = false;
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

void run_sched(const SchedArgs& args) {
  if (ends_with(args.input, ".policy")) {
    fail(args.input +
         ": reading the task model from a policy file is not supported yet (the policy "
         "compiler is not part of this build); give the tasks as CSV or JSON, see docs/sched.md");
    return;
  }
  Result<sched::TaskSet> read = sched::read_task_set_file(args.input);
  if (!read) return fail(read.error());
  sched::TaskSet set = std::move(*read);

  // Where C^o comes from: the flag, a measured file, the input, or nowhere.
  std::optional<sched::Nanos> forced;
  std::string source = "input";
  if (!args.overhead.empty()) {
    Result<sched::Nanos> d = sched::parse_duration(args.overhead);
    if (!d) return fail("--overhead: " + d.error());
    forced = *d;
    source = "--overhead";
  } else if (!args.overhead_from.empty()) {
    Result<sched::MeasuredOverhead> m = sched::read_overhead_file(args.overhead_from);
    if (!m) return fail("--overhead-from: " + m.error());
    forced = m->overhead;
    source = "measured (" + args.overhead_from +
             (m->measured_on.empty() ? "" : ", on " + m->measured_on) +
             (m->method.empty() ? "" : ", " + m->method) + ")";
  } else {
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
    fmt::print("{}\n", out.dump(2));
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
  fmt::print("\nsensitivity (binary search on the exact test):\n");
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

}  // namespace

void register_sched(CLI::App& app) {
  auto args = std::make_shared<SchedArgs>();
  auto* cmd = app.add_subcommand(
      "sched", "Schedulability with checking overhead (response-time analysis, sensitivity)");
  cmd->add_option("taskset", args->input, "Task set: CSV or JSON (docs/sched.md), or a policy")
      ->required();
  auto* over = cmd->add_option("--overhead", args->overhead,
                               "Per-command checking cost C^o for every task, e.g. 40us");
  cmd->add_option("--overhead-from", args->overhead_from,
                  "JSON file with the measured C^o written by `contego bench`")
      ->excludes(over);
  cmd->add_option("--assign", args->assign, "Priorities: given (default), rm, dm or audsley");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_flag("--no-sensitivity", args->no_sensitivity, "Skip the sensitivity analysis");
  cmd->callback([args] { run_sched(*args); });
}

}  // namespace contego::cli
