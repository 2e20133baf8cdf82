#include "learn/replay.h"

#include <algorithm>
#include <fmt/format.h>
#include <memory>
#include <tuple>

#include "contego/core/checker.h"

#include "monitor/audit_log.h"

namespace contego::learn {
namespace {

std::string hex(const uint8_t* bytes, size_t n) {
  std::string s;
  for (size_t i = 0; i < n; ++i) s += fmt::format("{}{:02x}", i ? " " : "", bytes[i]);
  return s;
}

// The checker's host while one recorded transaction is re-decided: its
// readings as the samples, and the verdicts it audits collected.
struct Replayer {
  const image::ImageModel* model = nullptr;
  monitor::NameTable names;
  const TraceDecision* current = nullptr;
  std::vector<Verdict> audited;

  static uint32_t read_sample(void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                              uint64_t* taken_at_us) {
    auto* self = static_cast<Replayer*>(ctx);
    if (self->current == nullptr || device >= self->model->devices.size()) return 0;
    auto it = self->current->readings.find(self->model->devices[device].name);
    if (it == self->current->readings.end() || !it->second.present) return 0;
    const SeenReading& r = it->second;
    const uint32_t n = std::min<uint32_t>(capacity, static_cast<uint32_t>(r.bytes.size()));
    std::copy_n(r.bytes.begin(), n, buf);
    if (taken_at_us != nullptr) {
      *taken_at_us = self->current->t_us > r.age_us ? self->current->t_us - r.age_us : 0;
    }
    return n;
  }

  static void audit(void* ctx, const core::AuditRecord* r) {
    auto* self = static_cast<Replayer*>(ctx);
    if (core::is_follow_up(r->reason)) return;  // follows the verdict of another request
    const monitor::RecordNames n = self->names.of(*r);
    Verdict v;
    v.decision = core::decision_name(r->decision);
    v.reason = core::reason_name(r->reason);
    v.rule = n.rule != nullptr ? n.rule : "";
    v.command = n.command != nullptr ? n.command : "";
    if (r->substitute != nullptr) v.substitute = hex(r->substitute, r->substitute_len);
    self->audited.push_back(std::move(v));
  }
};

// The job numbers of each task: the log's own, unless the log's grid was
// another period than the policy's (estimated from the jobs and times it
// recorded): then recomputed on the policy's period from the task's first
// record.
std::map<std::string, std::vector<uint32_t>> job_numbers(const Trace& trace,
                                                         const image::ImageModel& model,
                                                         std::map<std::string, std::string>& how) {
  std::map<std::string, std::vector<size_t>> of_task;
  for (size_t i = 0; i < trace.decisions.size(); ++i) of_task[trace.decisions[i].task].push_back(i);
  std::map<std::string, std::vector<uint32_t>> jobs;
  for (const auto& [task, idx] : of_task) {
    std::vector<uint32_t>& out = jobs[task];
    for (size_t i : idx) out.push_back(trace.decisions[i].job);
    auto t = std::find_if(model.tasks.begin(), model.tasks.end(),
                          [&name = task](const auto& r) { return r.name == name; });
    if (t == model.tasks.end()) continue;
    const uint64_t period = t->record.period_us;
    const TraceDecision& first = trace.decisions[idx.front()];
    const TraceDecision& last = trace.decisions[idx.back()];
    how[task] = "the log's jobs";
    if (period == 0) {
      std::fill(out.begin(), out.end(), 0);
      how[task] = "no period in the policy: the checker's own windows";
      continue;
    }
    if (last.job >= first.job + 3 && first.job != 0) {
      const uint64_t recorded = (last.t_us - first.t_us) / (last.job - first.job);
      const uint64_t off = recorded > period ? recorded - period : period - recorded;
      if (off * 10 <= period) continue;  // the same grid
    } else if (first.job != 0) {
      continue;  // too short to tell: keep the log's
    }
    for (size_t k = 0; k < idx.size(); ++k) {
      out[k] = static_cast<uint32_t>((trace.decisions[idx[k]].t_us - first.t_us) / period + 1);
    }
    how[task] = fmt::format("recomputed on the policy's {} ms period (the log's grid differs)",
                            static_cast<double>(period) / 1000.0);
  }
  return jobs;
}

bool differs(const TraceDecision& r, const Verdict& v) {
  if (r.decision != v.decision) return true;
  if (r.decision == "allow") return false;
  return r.rule != v.rule || (r.decision == "failsafe" && r.substitute != v.substitute);
}

}  // namespace

std::string verdict_text(const Verdict& v) {
  if (v.decision.empty()) return "(no such decision)";
  std::string s = v.decision;
  if (v.decision == "allow") return s;
  if (!v.rule.empty()) s += " by " + v.rule;
  s += " (" + v.reason + ")";
  return s;
}

Result<ReplayReport> replay(const Trace& trace, const image::ImageModel& model,
                            const std::vector<uint8_t>& image) {
  auto checker = std::make_unique<core::Checker>();
  const core::LoadResult lr = checker->load(image.data(), static_cast<uint32_t>(image.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(fmt::format("the policy image was refused by the verifier: {}",
                                  core::load_status_name(lr.status)));
  }
  Replayer host_state;
  host_state.model = &model;
  host_state.names = monitor::name_table(model);
  core::Host host{};
  host.context = &host_state;
  host.read_sample = &Replayer::read_sample;
  host.audit = &Replayer::audit;
  checker->set_host(host);

  ReplayReport report;
  const auto jobs = job_numbers(trace, model, report.jobs);
  std::map<std::string, size_t> seen_of_task;  // position in jobs[task]
  auto task_id = [&](const std::string& name) -> int {
    for (size_t i = 0; i < model.tasks.size(); ++i) {
      if (model.tasks[i].name == name) return static_cast<int>(i);
    }
    return -1;
  };
  auto device_id = [&](const std::string& name) -> int {
    for (size_t i = 0; i < model.devices.size(); ++i) {
      if (model.devices[i].name == name) return static_cast<int>(i);
    }
    return -1;
  };
  auto drive_safe = [&](uint32_t devices) {
    for (uint16_t d = 0; d < checker->device_count(); ++d) {
      if (d < 32 && ((devices >> d) & 1u) == 0) continue;
      if ((checker->device(d).role & core::kRoleActuator) == 0) continue;
      core::Verdict v{};
      (void)checker->safe_state(d, &v);  // the model takes it as the monitor's bus did
    }
  };
  std::map<std::string, bool> unknown_tasks;
  size_t next_event = 0;
  const std::vector<TraceDecision>& ds = trace.decisions;
  for (size_t i = 0; i < ds.size();) {
    for (; next_event < trace.events.size() && trace.events[next_event].before <= i; ++next_event) {
      const TraceEvent& e = trace.events[next_event];
      if (e.kind == TraceEvent::Kind::kReset) {
        if (int d = device_id(e.name); d >= 0) checker->reset_latch(static_cast<uint16_t>(d));
      } else if (e.kind == TraceEvent::Kind::kSessionEnd) {
        const int t = task_id(e.name);
        if (t < 0) continue;
        drive_safe(model.access[static_cast<size_t>(t)].actuate_devices);
        checker->end_session(static_cast<uint16_t>(t));
      } else {
        drive_safe(UINT32_MAX);
      }
    }
    size_t end = i + 1;
    while (end < ds.size() && same_transaction(ds[i], ds[end])) ++end;
    const TraceDecision& r = ds[i];
    const int task = task_id(r.task);
    host_state.audited.clear();
    const uint32_t job = jobs.at(r.task)[seen_of_task[r.task]];
    seen_of_task[r.task] += end - i;
    if (task < 0) {
      unknown_tasks[r.task] = true;
      host_state.audited.push_back({"reject", "unknown-task", "", "", ""});
    } else {
      core::Transaction tx{};
      tx.task = static_cast<uint16_t>(task);
      tx.bus = r.bus;
      tx.kind = r.read ? core::TxKind::kRead : core::TxKind::kWrite;
      tx.addr = r.addr;
      tx.ten_bit = r.addr > 0x7f ? 1 : 0;
      tx.job = job;
      tx.len = static_cast<uint32_t>(r.bytes.size());
      tx.bytes = r.bytes.data();
      tx.now_us = r.t_us;
      host_state.current = &r;
      core::Verdict v{};
      checker->begin_transfer();
      checker->check(tx, &v);
      if (v.decision == core::Decision::kAllow || v.decision == core::Decision::kFailsafe) {
        checker->commit_transfer();
      } else {
        checker->abort_transfer(v.decision);
      }
      host_state.current = nullptr;
    }
    for (size_t k = i; k < end; ++k) {
      ++report.decisions;
      const size_t at = k - i;
      Verdict v = at < host_state.audited.size() ? host_state.audited[at] : Verdict{};
      if (differs(ds[k], v)) report.changes.push_back({&ds[k], std::move(v)});
    }
    i = end;
  }
  for (const auto& [name, _] : unknown_tasks) {
    report.notes.push_back(fmt::format(
        "task `{}` of the log is not in the policy: its commands replay as refused", name));
  }
  if (!ds.empty() &&
      std::none_of(ds.begin(), ds.end(), [](const auto& d) { return d.has_readings; })) {
    report.notes.push_back(
        "the log records no sensor readings (written before they were recorded): every signal "
        "an invariant reads is unavailable in the replay");
  }
  return report;
}

std::string format_replay(const ReplayReport& report, const std::string& policy_name) {
  std::string out = fmt::format("replayed {} recorded decisions against {}: {} would change\n",
                                report.decisions, policy_name, report.changes.size());
  for (const auto& [task, how] : report.jobs) out += fmt::format("  task {}: {}\n", task, how);
  for (const std::string& n : report.notes) out += "  note: " + n + "\n";
  if (report.changes.empty()) return out;
  // Grouped by task, command and the two verdicts; the largest groups first.
  struct Group {
    uint64_t count = 0;
    std::vector<std::string> first;
  };
  std::map<std::tuple<std::string, std::string, std::string, std::string>, Group> groups;
  std::map<std::pair<std::string, std::string>, uint64_t> transitions;
  for (const Change& c : report.changes) {
    const TraceDecision& r = *c.record;
    const std::string command =
        (r.device.empty() ? fmt::format("i2c-{} 0x{:02x}", r.bus, r.addr) : r.device) + "." +
        (r.command.empty() ? (r.read ? "read" : "[" + hex(r.bytes.data(), r.bytes.size()) + "]")
                           : r.command);
    const Verdict recorded{r.decision, r.reason, r.rule, r.command, r.substitute};
    Group& g = groups[{r.task, command, verdict_text(recorded), verdict_text(c.replayed)}];
    if (++g.count <= 3) g.first.push_back(fmt::format("{}:{}", r.file, r.line));
    ++transitions[{r.decision, c.replayed.decision.empty() ? "none" : c.replayed.decision}];
  }
  std::vector<std::pair<Group, std::tuple<std::string, std::string, std::string, std::string>>>
      rows;
  for (const auto& [k, g] : groups) rows.emplace_back(g, k);
  std::stable_sort(rows.begin(), rows.end(),
                   [](const auto& a, const auto& b) { return a.first.count > b.first.count; });
  out += fmt::format("{:<12} {:<28} {:>6}  {:<40} {:<40} {}\n", "task", "command", "count",
                     "recorded", "replayed", "first lines");
  for (const auto& [g, k] : rows) {
    const auto& [task, command, recorded, replayed] = k;
    out += fmt::format("{:<12} {:<28} {:>6}  {:<40} {:<40} {}\n", task, command, g.count, recorded,
                       replayed, fmt::join(g.first, ", "));
  }
  std::vector<std::string> summary;
  for (const auto& [k, n] : transitions)
    summary.push_back(fmt::format("{} -> {}: {}", k.first, k.second, n));
  out += fmt::format("changes: {}\n", fmt::join(summary, ", "));
  return out;
}

}  // namespace contego::learn
