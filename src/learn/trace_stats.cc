#include "learn/trace_stats.h"

#include <algorithm>
#include <fmt/format.h>

#include "devices/codec.h"

namespace contego::learn {
namespace {

uint64_t with_margin(uint64_t n, uint32_t percent) { return n + (n * percent + 99) / 100; }

bool acted(const TraceDecision& d) {
  return !d.read && !d.command.empty() && d.reason != "staged" &&
         (d.decision == "allow" || d.complain);
}

std::string ms_text(uint64_t us) {
  return us % 1000 == 0 ? fmt::format("{} ms", us / 1000)
                        : fmt::format("{:.1f} ms", static_cast<double>(us) / 1000.0);
}

struct Collector {
  const Trace& trace;
  const policy::CompileOutput& observed;
  uint32_t margin;
  TraceStats out;
  // Per task: the times of its acting commands, all and per (device, command).
  std::map<std::string, std::vector<uint64_t>> acting_times;
  std::map<std::string, std::map<std::pair<std::string, std::string>, std::vector<uint64_t>>>
      command_times;
  uint64_t unacted = 0, undecoded = 0, unknown_device = 0, unallowed_complain = 0;
  uint64_t foreign_task = 0, foreign_device = 0;  // names the observe policy does not declare

  const devices::ProfileSpec* profile(const std::string& device) const {
    for (size_t d = 0; d < observed.model.devices.size(); ++d) {
      if (observed.model.devices[d].name == device && d < observed.profiles.size()) {
        return &observed.profiles[d];
      }
    }
    return nullptr;
  }
  const devices::CommandSpec* command(const std::string& device, const std::string& name) const {
    const devices::ProfileSpec* p = profile(device);
    if (p == nullptr) return nullptr;
    for (const auto& c : p->commands) {
      if (c.name == name) return &c;
    }
    return nullptr;
  }

  void record(size_t i);
  void periods();
  void sensor_relations();
  void sequences();
};

void Collector::record(size_t i) {
  const TraceDecision& d = trace.decisions[i];
  if (d.device.empty()) {
    ++unknown_device;
    return;
  }
  // Names the observe policy does not declare (a log of another policy)
  // cannot become rules of this one.
  const bool known_task = std::any_of(observed.model.tasks.begin(), observed.model.tasks.end(),
                                      [&](const auto& t) { return t.name == d.task; });
  if (!known_task || profile(d.device) == nullptr) {
    ++(known_task ? foreign_device : foreign_task);
    return;
  }
  TaskStats& t = out.tasks[d.task];
  TaskDeviceStats& td = t.devices[d.device];
  const devices::CommandSpec* spec = d.command.empty() ? nullptr : command(d.device, d.command);
  const bool went_through = d.decision == "allow" || d.complain;
  if (d.read || (spec != nullptr && spec->command_class == core::CommandClass::kQuery)) {
    if (!went_through) {
      ++unacted;
      return;
    }
    td.reads = true;
    ++td.read_count;
    t.records.push_back(i);
    return;
  }
  if (d.command.empty()) {
    ++undecoded;
    return;
  }
  if (d.reason == "staged" && went_through) {
    t.records.push_back(i);
    return;
  }
  if (!acted(d)) {
    ++unacted;
    return;
  }
  if (d.complain && d.reason == "access-denied") ++unallowed_complain;
  td.actuates = true;
  ++td.acting_count;
  t.records.push_back(i);
  acting_times[d.task].push_back(d.t_us);
  command_times[d.task][{d.device, d.command}].push_back(d.t_us);
  CommandStats& c = out.commands[{d.device, d.command}];
  if (c.acted++ == 0) {
    c.first_task = d.task;
    c.first = &d;
  }
  if (c.fields.size() < d.fields.size()) c.fields.resize(d.fields.size());
  for (size_t f = 0; f < d.fields.size(); ++f) c.fields[f].add(d.fields[f]);
  if (spec != nullptr && spec->repeat > 1) c.channels.insert(d.index);
}

// A task's period: the interval at which its most frequent command repeats,
// when it repeats regularly (at least 5 times, 70 % of the intervals within
// half of their median of it); else the observe policy's.
void Collector::periods() {
  for (auto& [task, t] : out.tasks) {
    uint64_t declared = 0;
    for (const auto& r : observed.model.tasks) {
      if (r.name == task) declared = r.record.period_us;
    }
    const auto& per = command_times[task];
    const std::vector<uint64_t>* most = nullptr;
    std::string most_name;
    for (const auto& [key, times] : per) {
      if (most == nullptr || times.size() > most->size()) {
        most = &times;
        most_name = key.first + "." + key.second;
      }
    }
    t.period_us = declared;
    t.period_source = fmt::format("the observe policy's period ({}): {}", ms_text(declared),
                                  most == nullptr ? "nothing of it acted"
                                                  : "no command repeated regularly enough to "
                                                    "measure one");
    if (most != nullptr && most->size() >= 5) {
      std::vector<uint64_t> gaps;
      for (size_t k = 1; k < most->size(); ++k) gaps.push_back((*most)[k] - (*most)[k - 1]);
      std::vector<uint64_t> sorted = gaps;
      std::sort(sorted.begin(), sorted.end());
      const uint64_t median = sorted[sorted.size() / 2];
      const auto near = std::count_if(gaps.begin(), gaps.end(), [&](uint64_t g) {
        return g * 2 >= median && g * 2 <= median * 3;
      });
      if (median >= 1000 && static_cast<uint64_t>(near) * 10 >= gaps.size() * 7) {
        const uint64_t grain = median >= 20000 ? 10000 : 1000;
        t.period_us = std::max<uint64_t>(grain, (median - median / 20) / grain * grain);
        t.period_source = fmt::format(
            "period measured from the trace: {} repeats every {} (median of {} intervals, {} "
            "of them within half of it); the period is set a little under it, so that one "
            "iteration's commands share a window",
            most_name, ms_text(median), gaps.size(), near);
      }
    }
    if (t.period_us == 0) t.period_us = 1000000;
    std::vector<uint64_t>& all = acting_times[task];
    std::sort(all.begin(), all.end());
    t.max_per_window = window_max(all, t.period_us);
    t.actuations = std::max<uint64_t>(1, with_margin(t.max_per_window, margin));
    for (const auto& [key, times] : per) {
      const uint64_t n = window_max(times, t.period_us);
      t.devices[key.first].per_command_window_max[key.second] = n;
      t.actuations = std::max(t.actuations, with_margin(n, margin));
    }
  }
}

// Where the commands of one substitution group (fwd / left / right) acted
// with disjoint values of a sensor field, suggest the invariant that says so.
void Collector::sensor_relations() {
  struct Interval {
    int64_t lo = INT64_MAX, hi = INT64_MIN;
    uint64_t n = 0;
  };
  using Fields = std::map<std::string, Interval>;  // "line.raw2" -> values seen
  std::map<std::pair<std::string, std::string>, std::map<std::string, Fields>> by_group;
  for (const TraceDecision& d : trace.decisions) {
    if (!acted(d)) continue;
    const devices::CommandSpec* spec = command(d.device, d.command);
    if (spec == nullptr || spec->group.empty()) continue;
    Fields& per = by_group[{d.device, spec->group}][d.command];
    for (const auto& [sensor, r] : d.readings) {
      const devices::ProfileSpec* sp = r.present ? profile(sensor) : nullptr;
      if (sp == nullptr) continue;
      for (const auto& field : sp->sample_fields) {
        auto v = devices::extract_field(field.geometry, r.bytes);
        if (!v.ok()) continue;
        Interval& iv = per[sensor + "." + field.name];
        iv.lo = std::min(iv.lo, *v);
        iv.hi = std::max(iv.hi, *v);
        ++iv.n;
      }
    }
  }
  for (auto& [key, commands] : by_group) {
    const auto& [device, group] = key;
    // The safe state is always allowed: never a choice to judge.
    for (const auto& d : observed.summary.devices) {
      if (d.name != device) continue;
      for (const std::string& s : d.safe) {
        if (s.ends_with("()")) commands.erase(s.substr(0, s.size() - 2));
      }
    }
    if (commands.size() < 2) continue;
    std::vector<std::string> names;
    for (const auto& [cmd, _] : commands) names.push_back(cmd);
    const size_t before = out.suggestions.size();
    for (const auto& [cmd, fields] : commands) {
      for (const auto& [field, iv] : fields) {
        std::vector<std::string> others;
        bool disjoint = true;
        for (const auto& [other, other_fields] : commands) {
          if (other == cmd) continue;
          auto it = other_fields.find(field);
          if (it == other_fields.end() || !(it->second.hi < iv.lo || it->second.lo > iv.hi)) {
            disjoint = false;
            break;
          }
          others.push_back(fmt::format("{} {}..{}", other, it->second.lo, it->second.hi));
        }
        if (!disjoint) continue;
        out.suggestions.push_back(
            {fmt::format("{}.{} acted {} times, always with {} in {}..{}; the other commands "
                         "of group `{}` only with: {}",
                         device, cmd, iv.n, field, iv.lo, iv.hi, group, fmt::join(others, ", ")),
             fmt::format("invariant SUGGEST_{}_{} on {}.{}: require {} in {}..{} else ignore", cmd,
                         field.substr(field.find('.') + 1), device, cmd, field, iv.lo, iv.hi)});
        break;  // one field per command says it
      }
    }
    const size_t found = out.suggestions.size() - before;
    out.findings.push_back(fmt::format(
        "{}.{{{}}} (substitution group `{}`): each acted in the trace, so access and ranges allow "
        "all of them; which one is right for a reading is not in the generated rules (a wrong "
        "direction is not stopped): {}",
        device, fmt::join(names, ", "), group,
        found != 0 ? fmt::format("{} suggested invariant(s) at the end of the policy", found)
                   : std::string("no sensor reading separated them; write the invariant by hand "
                                 "(as rover.policy's INV1-INV3)")));
  }
}

// A field that cycled through a few values (the gripper's open, close, open)
// in every session of the task that sent it: suggest a `sequence`.
void Collector::sequences() {
  std::map<std::string, std::vector<size_t>> ends;  // task -> decision index of each session end
  for (const TraceEvent& e : trace.events) {
    if (e.kind == TraceEvent::Kind::kSessionEnd) ends[e.name].push_back(e.before);
  }
  struct Key {
    std::string task, device, command;
    uint32_t channel;
    auto operator<=>(const Key&) const = default;
  };
  // Per key and field: the values in order, one list per session.
  std::map<Key, std::vector<std::map<size_t, std::vector<int64_t>>>> seen;
  for (size_t i = 0; i < trace.decisions.size(); ++i) {
    const TraceDecision& d = trace.decisions[i];
    if (!acted(d)) continue;
    const std::vector<size_t>& e = ends[d.task];
    const size_t session = static_cast<size_t>(std::upper_bound(e.begin(), e.end(), i) - e.begin());
    auto& sessions = seen[{d.task, d.device, d.command, d.index}];
    if (sessions.size() <= session) sessions.resize(session + 1);
    for (size_t f = 0; f < d.fields.size(); ++f) sessions[session][f].push_back(d.fields[f]);
  }
  for (const auto& [key, sessions] : seen) {
    const devices::CommandSpec* spec = command(key.device, key.command);
    if (spec == nullptr) continue;
    for (size_t f = 0; f < spec->fields.size(); ++f) {
      std::vector<int64_t> cycle;
      size_t total = 0, used = 0;
      for (const auto& s : sessions) {
        auto it = s.find(f);
        if (it == s.end()) continue;
        ++used;
        total += it->second.size();
        for (int64_t v : it->second) {
          if (std::find(cycle.begin(), cycle.end(), v) == cycle.end()) cycle.push_back(v);
        }
      }
      if (cycle.size() < 2 || cycle.size() > 4 || total < cycle.size() + 1) continue;
      bool follows = true;
      for (const auto& s : sessions) {
        auto it = s.find(f);
        for (size_t k = 0; it != s.end() && k < it->second.size(); ++k) {
          follows = follows && it->second[k] == cycle[k % cycle.size()];
        }
      }
      if (!follows) continue;
      std::vector<std::string> values;
      for (int64_t v : cycle) values.push_back(std::to_string(v));
      const std::string channel =
          spec->repeat > 1 ? fmt::format("({})", key.channel) : std::string();
      out.suggestions.push_back(
          {fmt::format("{}.{}{} `{}` went {} in order in each of {} session(s) of task {} ({} "
                       "commands)",
                       key.device, key.command, channel, spec->fields[f].name,
                       fmt::join(values, ", "), used, key.task, total),
           fmt::format("invariant SEQ_{}_{}{} on {}.{}{}: sequence {} [{}] else ignore", key.device,
                       key.command, spec->repeat > 1 ? "_" + std::to_string(key.channel) : "",
                       key.device, key.command, channel, spec->fields[f].name,
                       fmt::join(values, ", "))});
    }
  }
}

}  // namespace

uint64_t window_max(const std::vector<uint64_t>& times, uint64_t window_us) {
  uint64_t best = 0;
  size_t j = 0;
  for (size_t i = 0; i < times.size(); ++i) {
    while (times[i] - times[j] >= window_us) ++j;
    best = std::max<uint64_t>(best, i - j + 1);
  }
  return best;
}

Result<TraceStats> collect_stats(const Trace& trace, const policy::CompileOutput& observed,
                                 uint32_t margin_percent) {
  Collector c{trace, observed, margin_percent, {}, {}, {}};
  if (!trace.decisions.empty()) {
    c.out.first_us = trace.decisions.front().t_us;
    c.out.last_us = trace.decisions.back().t_us;
  }
  for (size_t i = 0; i < trace.decisions.size(); ++i) c.record(i);
  if (c.out.commands.empty()) {
    return make_error(
        "no command of the logs acted (every one was dropped, or only reads were recorded): "
        "record the programs under the observe policy with --complain");
  }
  c.periods();
  c.sensor_relations();
  c.sequences();
  auto& f = c.out.findings;
  if (c.unacted != 0) {
    f.push_back(
        fmt::format("{} recorded command(s) were dropped when recorded (not complain "
                    "mode) and are not learned from",
                    c.unacted));
  }
  if (c.undecoded != 0) {
    f.push_back(
        fmt::format("{} write(s) the device profiles could not decode are not allowed "
                    "by the generated policy",
                    c.undecoded));
  }
  if (c.unknown_device != 0) {
    f.push_back(
        fmt::format("{} transaction(s) went to addresses no device of the observe policy "
                    "declares; the generated policy refuses them",
                    c.unknown_device));
  }
  if (c.foreign_task + c.foreign_device != 0) {
    f.push_back(
        fmt::format("{} decision(s) name a task and {} a device the observe policy does "
                    "not declare (a log of another policy?): not learned from",
                    c.foreign_task, c.foreign_device));
  }
  if (c.unallowed_complain != 0) {
    f.push_back(fmt::format(
        "{} command(s) were recorded without access in the observe policy (complain: "
        "access-denied): a register-map device's writes were then counted one by one; add "
        "`allow TASK -> DEVICE` to the observe policy and record again",
        c.unallowed_complain));
  }
  return std::move(c.out);
}

}  // namespace contego::learn
