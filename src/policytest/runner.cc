#include "policytest/runner.h"

#include <algorithm>
#include <fmt/format.h>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "contego/core/checker.h"

#include "devices/codec.h"
#include "devices/lower.h"
#include "devices/model_profile.h"

namespace contego::policytest {
namespace {

struct Sample {
  bool present = false;
  std::vector<uint8_t> bytes;
  uint64_t taken_at_us = 0;
};

// Everything one case changes as it runs.
struct CaseState {
  uint16_t task = core::kNoTask;
  bool task_set = false;
  uint32_t job = 0;
  uint64_t now_us = 0;
  std::map<uint16_t, Sample> samples;
  std::vector<core::AuditRecord> audits;  // of the current transaction (pointers cleared)
};

uint32_t read_sample(void* context, uint16_t device, uint8_t* buf, uint32_t capacity,
                     uint64_t* taken_at_us) {
  auto* state = static_cast<CaseState*>(context);
  auto it = state->samples.find(device);
  if (it == state->samples.end() || !it->second.present) return 0;
  const auto n = static_cast<uint32_t>(std::min<size_t>(capacity, it->second.bytes.size()));
  std::copy_n(it->second.bytes.begin(), n, buf);
  *taken_at_us = it->second.taken_at_us;
  return n;
}

void audit(void* context, const core::AuditRecord* record) {
  core::AuditRecord copy = *record;
  copy.original = nullptr;
  copy.substitute = nullptr;
  static_cast<CaseState*>(context)->audits.push_back(copy);
}

std::string hex(std::span<const uint8_t> bytes) {
  std::string s = "[";
  for (size_t i = 0; i < bytes.size(); ++i) s += fmt::format("{}{:02x}", i ? " " : "", bytes[i]);
  return s + "]";
}

std::string errno_text(int e) {
  for (const char* name : {"EPERM", "EIO", "EBADF", "EAGAIN", "EACCES", "EBUSY", "EINVAL"}) {
    if (errno_from_name(name) == e) return name;
  }
  return std::to_string(e);
}

class Runner {
 public:
  Runner(const TestFile& file, const image::ImageModel& model, std::span<const uint8_t> image,
         std::span<const devices::ProfileSpec> profiles)
      : file_(file), model_(model), image_(image), given_(profiles) {}

  Result<RunReport> run() {
    report_.file_name = file_.file_name;
    if (!given_.empty() && given_.size() != model_.devices.size()) {
      return make_error(fmt::format("{} device profiles given for {} devices", given_.size(),
                                    model_.devices.size()));
    }
    for (uint16_t d = 0; d < model_.devices.size(); ++d) {
      if (!given_.empty()) {
        profiles_.push_back(given_[d]);
        continue;
      }
      Result<devices::ProfileSpec> p = devices::profile_from_model(model_, d);
      if (!p) return make_error(p.error());
      profiles_.push_back(std::move(*p));
    }
    for (const auto& inv : model_.invariants) report_.invariants.push_back(inv.name);
    for (const auto& rate : model_.rates) report_.rates.push_back(rate.name);
    for (const TestCase& c : file_.cases) {
      if (Status s = run_case(c); !s) return make_error(s.error());
    }
    for (size_t i = 0; i < model_.invariants.size(); ++i) {
      if (!fired_invariants_.count(i))
        report_.uncovered_invariants.push_back(model_.invariants[i].name);
    }
    for (size_t i = 0; i < model_.rates.size(); ++i) {
      if (!fired_rates_.count(i)) report_.uncovered_rates.push_back(model_.rates[i].name);
    }
    return std::move(report_);
  }

 private:
  void error(Loc loc, const std::string& message) {
    report_.errors.push_back(
        fmt::format("{}:{}:{}: error: {}", file_.file_name, loc.line, loc.column, message));
  }

  std::optional<uint16_t> device_id(const std::string& name) const {
    for (uint16_t d = 0; d < model_.devices.size(); ++d) {
      if (model_.devices[d].name == name) return d;
    }
    return std::nullopt;
  }

  std::string device_list() const {
    std::string s;
    for (const auto& d : model_.devices) s += (s.empty() ? "" : ", ") + d.name;
    return s.empty() ? "none" : s;
  }

  Status run_case(const TestCase& c) {
    ++report_.cases;
    auto checker = std::make_unique<core::Checker>();
    core::LoadResult lr = checker->load(image_.data(), static_cast<uint32_t>(image_.size()));
    if (lr.status != core::LoadStatus::kOk) {
      return make_error(
          fmt::format("the policy image is refused by the verifier: {} (section {}, "
                      "record {})",
                      core::load_status_name(lr.status), lr.section, lr.index));
    }
    CaseState state;
    checker->set_host(core::Host{&state, &read_sample, &audit});
    // One mirror per device of what reached the bus, to decode substitutes.
    std::vector<devices::HostDecoder> mirrors;
    for (const devices::ProfileSpec& p : profiles_) mirrors.emplace_back(p);

    const size_t errors_before = report_.errors.size();
    bool failed = false;
    auto apply = [&](const Action& a) {
      if (const auto* t = std::get_if<SetTask>(&a)) {
        set_task(*t, state);
      } else if (const auto* j = std::get_if<SetJob>(&a)) {
        state.job = j->job;
      } else if (const auto* tm = std::get_if<SetTime>(&a)) {
        state.now_us = tm->relative ? state.now_us + tm->us : tm->us;
      } else if (const auto* s = std::get_if<SetSensor>(&a)) {
        set_sensor(*s, state);
      } else if (const auto* st = std::get_if<Step>(&a)) {
        if (!run_step(c, *st, *checker, state, mirrors)) failed = true;
      }
    };
    for (const Action& a : file_.defaults) apply(a);
    for (const Action& a : c.actions) apply(a);
    if (failed || report_.errors.size() != errors_before) ++report_.failed_cases;
    return {};
  }

  void set_task(const SetTask& t, CaseState& state) {
    state.task_set = true;
    if (t.task == "none") {
      state.task = core::kNoTask;
      return;
    }
    for (uint16_t i = 0; i < model_.tasks.size(); ++i) {
      if (model_.tasks[i].name == t.task) {
        state.task = i;
        return;
      }
    }
    std::string known;
    for (const auto& task : model_.tasks) known += (known.empty() ? "" : ", ") + task.name;
    error(t.loc, fmt::format("unknown task '{}' (tasks: {}; 'none' = an undeclared client)", t.task,
                             known.empty() ? "none" : known));
  }

  void set_sensor(const SetSensor& s, CaseState& state) {
    auto id = device_id(s.device);
    if (!id) {
      error(s.loc, fmt::format("unknown device '{}' (devices: {})", s.device, device_list()));
      return;
    }
    const devices::ProfileSpec& p = profiles_[*id];
    if ((p.role & core::kRoleSensor) == 0) {
      error(s.loc, fmt::format("device '{}' is not a sensor", s.device));
      return;
    }
    Sample sample;
    sample.taken_at_us = state.now_us;
    if (s.none) {
      state.samples[*id] = sample;
      return;
    }
    sample.present = true;
    if (s.sample) {
      sample.bytes = *s.sample;
    } else {
      // Start from the previous sample so a statement can change one field.
      auto prev = state.samples.find(*id);
      std::vector<devices::FieldValue> values;
      for (size_t k = 0; k < s.fields.size(); ++k) {
        const auto& [name, list] = s.fields[k];
        if (s.is_list[k]) {
          for (size_t i = 0; i < list.size(); ++i) {
            values.push_back({name + std::to_string(i), list[i]});
          }
        } else {
          values.push_back({name, list[0]});
        }
      }
      Result<std::vector<uint8_t>> bytes = devices::encode_sample(p, values);
      if (!bytes) {
        error(s.loc, fmt::format("sensor '{}': {}", s.device, bytes.error()));
        return;
      }
      sample.bytes = std::move(*bytes);
      if (prev != state.samples.end() && prev->second.present) {
        // Keep the fields this statement does not name.
        std::vector<uint8_t> merged = prev->second.bytes;
        merged.resize(sample.bytes.size());
        for (const devices::FieldSpec& f : p.sample_fields) {
          bool named = false;
          for (const auto& v : values) named = named || v.name == f.name;
          if (!named) continue;
          for (uint32_t b = 0; b < f.geometry.nbytes; ++b) {
            merged[f.geometry.offset + b] = sample.bytes[f.geometry.offset + b];
          }
        }
        sample.bytes = std::move(merged);
      }
    }
    state.samples[*id] = std::move(sample);
  }

  // The transactions of a step: a raw one, or the writes of an encoded command.
  bool transactions(const Step& st, std::vector<std::vector<uint8_t>>& writes, uint8_t& bus,
                    uint16_t& addr) {
    if (!st.call) {
      writes.push_back(st.bytes);
      bus = st.bus;
      addr = st.addr;
      return true;
    }
    const Call& call = *st.call;
    auto id = device_id(call.device);
    if (!id) {
      error(call.loc, fmt::format("unknown device '{}' (devices: {})", call.device, device_list()));
      return false;
    }
    const devices::ProfileSpec& p = profiles_[*id];
    const devices::CommandSpec* cmd = devices::find_command(p, call.command);
    if (cmd == nullptr) {
      std::string known;
      for (const auto& k : p.commands) known += (known.empty() ? "" : ", ") + k.name;
      error(call.loc, fmt::format("device '{}' has no command '{}' (commands: {})", call.device,
                                  call.command, known));
      return false;
    }
    devices::EncodeOptions options;
    std::vector<devices::FieldValue> values;
    size_t positional = 0;
    bool indexed = cmd->repeat > 1;
    for (const Arg& a : call.args) {
      if (!a.name.empty()) {
        values.push_back({a.name, a.value});
        continue;
      }
      if (indexed && positional == 0) {
        if (a.value < 0) {
          error(call.loc, "negative group index");
          return false;
        }
        options.index = static_cast<uint32_t>(a.value);
      } else {
        const size_t f = positional - (indexed ? 1 : 0);
        if (f >= cmd->fields.size()) {
          error(call.loc, fmt::format("{}.{} takes {} value(s){}", call.device, call.command,
                                      cmd->fields.size(), indexed ? " after the index" : ""));
          return false;
        }
        values.push_back({cmd->fields[f].name, a.value});
      }
      ++positional;
    }
    const core::DeviceRecord& d = model_.devices[*id].record;
    // Register maps: one write per register works whatever the auto-increment
    // state; devices that always auto-increment get one block write.
    options.per_register = p.auto_increment != core::AutoIncrement::kAlways;
    Result<std::vector<std::vector<uint8_t>>> w =
        devices::encode_command(p, call.command, values, options);
    if (!w) {
      error(call.loc, w.error());
      return false;
    }
    writes = std::move(*w);
    bus = d.bus;
    addr = d.addr;
    return true;
  }

  // Decodes the emitted writes of a verdict with the mirror of the device.
  std::string describe_emits(const core::Verdict& v, std::vector<devices::HostDecoder>& mirrors,
                             std::vector<devices::DecodedCommand>* decoded) {
    std::string s;
    size_t offset = 0;
    for (uint32_t k = 0; k < v.emit_count && k < core::kMaxEmits; ++k) {
      const std::span<const uint8_t> bytes(v.emit_bytes + offset, v.emit_len[k]);
      offset += v.emit_len[k];
      if (v.device < mirrors.size()) {
        Result<std::vector<devices::DecodedCommand>> r = mirrors[v.device].write(bytes);
        if (r.ok()) {
          for (const auto& c : *r) {
            s += (s.empty() ? "" : ", ") + devices::describe(c);
            if (decoded != nullptr) decoded->push_back(c);
          }
          continue;
        }
      }
      s += (s.empty() ? "" : ", ") + hex(bytes);
    }
    return s;
  }

  std::string rule_name(const core::Verdict& v) {
    switch (v.rule_kind) {
      case core::RuleKind::kInvariant:
        fired_invariants_.insert(v.rule);
        return v.rule < model_.invariants.size() ? model_.invariants[v.rule].name
                                                 : fmt::format("invariant#{}", v.rule);
      case core::RuleKind::kRate:
        fired_rates_.insert(v.rule);
        return v.rule < model_.rates.size() ? model_.rates[v.rule].name
                                            : fmt::format("rate#{}", v.rule);
      case core::RuleKind::kAccess:
        return "access";
      case core::RuleKind::kLatch:
        return "latch";
      case core::RuleKind::kNoRule:
        break;
    }
    return "-";
  }

  // Compares an expected substitute with a decoded one; empty = match.
  std::string compare_call(const Call& want, const devices::DecodedCommand& got, uint16_t device) {
    if (!want.device.empty() &&
        (device >= model_.devices.size() || model_.devices[device].name != want.device)) {
      return fmt::format("substitute went to another device than '{}'", want.device);
    }
    if (got.command->name != want.command) {
      return fmt::format("substitute is {} not {}", got.command->name, want.command);
    }
    size_t positional = 0;
    const bool indexed = got.command->repeat > 1;
    for (const Arg& a : want.args) {
      std::optional<size_t> slot;
      if (a.name.empty()) {
        if (indexed && positional == 0) {
          ++positional;
          if (static_cast<int64_t>(got.index) != a.value) {
            return fmt::format("substitute index {} not {}", got.index, a.value);
          }
          continue;
        }
        slot = positional - (indexed ? 1 : 0);
        ++positional;
      } else {
        for (size_t f = 0; f < got.command->fields.size(); ++f) {
          if (got.command->fields[f].name == a.name) slot = f;
        }
      }
      if (!slot || *slot >= got.values.size()) {
        return fmt::format("{} has no field {}", got.command->name,
                           a.name.empty() ? std::to_string(positional) : a.name);
      }
      if (got.values[*slot] != a.value) {
        return fmt::format("{}.{} is {} not {}", got.command->name, got.command->fields[*slot].name,
                           got.values[*slot], a.value);
      }
    }
    return "";
  }

  bool run_step(const TestCase& c, const Step& st, core::Checker& checker, CaseState& state,
                std::vector<devices::HostDecoder>& mirrors) {
    StepOutcome out;
    out.case_name = c.name;
    out.line = st.loc.line;
    out.step = st.text;
    out.expected = st.expect.text;
    if (!state.task_set) {
      error(st.loc, "no task for this step (add `task NAME` to the test or the file's defaults)");
    }
    std::vector<std::vector<uint8_t>> writes;
    uint8_t bus = 0;
    uint16_t addr = 0;
    if (!transactions(st, writes, bus, addr)) {
      out.got = "(not run)";
      out.detail = "the step could not be encoded";
      report_.steps.push_back(out);
      return false;
    }
    core::Verdict v{};
    for (const std::vector<uint8_t>& w : writes) {
      core::Transaction tx{};
      tx.task = state.task;
      tx.bus = bus;
      tx.kind = st.kind;
      tx.addr = addr;
      tx.ten_bit = 0;
      tx.job = state.job;
      tx.len = static_cast<uint32_t>(w.size());
      tx.bytes = w.data();
      tx.now_us = state.now_us;
      state.audits.clear();
      checker.check(tx, &v);
      // Keep the bus mirror in step with what a host would write.
      if (v.decision != core::Decision::kFailsafe) describe_emits(v, mirrors, nullptr);
      if (v.decision != core::Decision::kAllow) break;  // later writes would not be sent
    }
    std::vector<devices::DecodedCommand> substitutes;
    out.rule = rule_name(v);
    out.reason = core::reason_name(v.reason);
    out.got = core::decision_name(v.decision);
    if (v.decision == core::Decision::kReject) out.got += " " + errno_text(v.reply_errno);
    if (v.decision == core::Decision::kFailsafe) {
      out.got += " " + describe_emits(v, mirrors, &substitutes);
    }
    const Expect& e = st.expect;
    std::string why;
    if (v.decision != e.decision) {
      why = "different decision";
    } else if (e.reply_errno && *e.reply_errno != v.reply_errno) {
      why = fmt::format("errno {} not {}", errno_text(v.reply_errno), errno_text(*e.reply_errno));
    } else if (!e.substitutes.empty()) {
      if (substitutes.size() != e.substitutes.size()) {
        why = fmt::format("{} substitute command(s), expected {}", substitutes.size(),
                          e.substitutes.size());
      }
      for (size_t k = 0; why.empty() && k < substitutes.size(); ++k) {
        why = compare_call(e.substitutes[k], substitutes[k], v.device);
      }
    }
    if (why.empty() && e.reason && *e.reason != out.reason) {
      why = fmt::format("reason {} not {}", out.reason, *e.reason);
    }
    if (why.empty() && e.rule && *e.rule != out.rule) {
      why = fmt::format("rule {} not {}", out.rule, *e.rule);
    }
    out.pass = why.empty();
    out.detail = why;
    report_.steps.push_back(out);
    return out.pass;
  }

  const TestFile& file_;
  const image::ImageModel& model_;
  std::span<const uint8_t> image_;
  std::span<const devices::ProfileSpec> given_;
  std::vector<devices::ProfileSpec> profiles_;
  RunReport report_;
  std::set<size_t> fired_invariants_;
  std::set<size_t> fired_rates_;
};

}  // namespace

Result<RunReport> run_tests(const TestFile& file, const image::ImageModel& model,
                            std::span<const uint8_t> image,
                            std::span<const devices::ProfileSpec> profiles) {
  return Runner(file, model, image, profiles).run();
}

std::string format_report(const RunReport& r) {
  const std::vector<std::string> head = {"CASE", "LINE", "STEP",  "EXPECTED",
                                         "GOT",  "RULE", "RESULT"};
  std::vector<std::vector<std::string>> rows;
  for (const StepOutcome& s : r.steps) {
    rows.push_back({s.case_name, std::to_string(s.line), s.step, s.expected, s.got,
                    s.rule == "-" ? s.reason : s.rule + " (" + s.reason + ")",
                    s.pass ? "PASS" : "FAIL"});
  }
  std::vector<size_t> width(head.size());
  for (size_t i = 0; i < head.size(); ++i) width[i] = head[i].size();
  for (const auto& row : rows) {
    for (size_t i = 0; i < row.size(); ++i) width[i] = std::max(width[i], row[i].size());
  }
  auto line = [&](const std::vector<std::string>& cells) {
    std::string s;
    for (size_t i = 0; i < cells.size(); ++i) {
      s += i + 1 == cells.size() ? cells[i] : fmt::format("{:<{}}  ", cells[i], width[i]);
    }
    return s + "\n";
  };
  std::string out = line(head);
  for (const auto& row : rows) out += line(row);
  for (const StepOutcome& s : r.steps) {
    if (!s.pass) {
      out += fmt::format("{}:{}: FAIL in \"{}\": {}\n", r.file_name, s.line, s.case_name, s.detail);
    }
  }
  for (const std::string& e : r.errors) out += e + "\n";
  auto coverage = [&](const char* what, const std::vector<std::string>& all,
                      const std::vector<std::string>& missing) {
    std::string s = fmt::format("coverage: {} {}/{} decided a verdict", what,
                                all.size() - missing.size(), all.size());
    if (!missing.empty()) {
      std::string names;
      for (const auto& n : missing) names += (names.empty() ? "" : ", ") + n;
      s += "; never exercised: " + names;
    }
    return s + "\n";
  };
  out += coverage("invariants", r.invariants, r.uncovered_invariants);
  out += coverage("rate rules", r.rates, r.uncovered_rates);
  size_t passed_steps = 0;
  for (const auto& s : r.steps) passed_steps += s.pass ? 1 : 0;
  out += fmt::format("{}: {} of {} cases passed ({} of {} steps){}\n", r.ok() ? "PASS" : "FAIL",
                     r.cases - r.failed_cases, r.cases, passed_steps, r.steps.size(),
                     r.errors.empty() ? "" : fmt::format(", {} error(s)", r.errors.size()));
  return out;
}

}  // namespace contego::policytest
