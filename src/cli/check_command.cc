// `contego check POLICY [--strict] [--json] [--emit IMAGE] [--emit-bundle BUNDLE]`: compiles a
// policy, verifies the image with the core's own verifier and prints what
// the policy means: tasks, the access matrix, signals, rate limits,
// invariants, the image size and the worst-case cost of one check.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "base/json_text.h"
#include "bundle/bundle.h"
#include "cli/bus_args.h"
#include "cli/command.h"
#include "cli/policy_load.h"
#include "cli/sched_closure.h"
#include "monitor/sha256.h"
#include "policy/compile.h"
#include "policy/diag/diag.h"

namespace contego::cli {
namespace {

bool write_output(const std::string& path, std::string_view bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) fmt::print(stderr, "contego check: cannot write `{}`\n", path);
  return static_cast<bool>(f);
}

std::string format_us(uint64_t us) {
  if (us == 0) return "0";
  if (us % 1000000 == 0) return fmt::format("{}s", us / 1000000);
  if (us % 1000 == 0) return fmt::format("{}ms", us / 1000);
  return fmt::format("{}us", us);
}

std::string format_ns(uint64_t ns) {
  if (ns == 0) return "-";
  if (ns % 1000 == 0) return format_us(ns / 1000);
  return fmt::format("{}ns", ns);
}

std::string pad(const std::string& s, size_t width) {
  return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}

// Who may run a task, as `contego monitor` checks it ("" when anyone allowed to connect may).
std::string identity_text(const policy::PolicySummary::Task& t) {
  std::string out;
  if (!t.user.empty()) out += " user " + t.user;
  if (!t.group.empty()) out += " group " + t.group;
  if (!t.unit.empty()) out += " unit " + t.unit;
  if (!t.cgroup.empty()) out += " cgroup " + t.cgroup;
  if (t.sessions != 1) out += fmt::format(" sessions {}", t.sessions);
  if (t.ignore_errno != 0) out += fmt::format(" ignore_errno {}", t.ignore_errno);
  return out;
}

void print_summary(const std::string& path, const policy::CompileOutput& out) {
  const auto& m = out.model;
  const auto& s = out.summary;
  fmt::print("policy {}: ok\n\n", path);

  fmt::print("tasks ({}):\n", m.tasks.size());
  fmt::print("  {}{}{}{}{}{}{}{}\n", pad("name", 14), pad("period", 9), pad("deadline", 9),
             pad("wcet", 9), pad("prio", 5), pad("N", 4), pad("overhead", 9), "exe");
  for (size_t i = 0; i < m.tasks.size(); ++i) {
    const auto& t = m.tasks[i].record;
    fmt::print("  {}{}{}{}{}{}{}{}\n", pad(m.tasks[i].name, 14), pad(format_us(t.period_us), 9),
               pad(format_us(t.deadline_us), 9), pad(format_us(t.wcet_us), 9),
               pad(std::to_string(t.priority), 5), pad(std::to_string(t.actuations_per_job), 4),
               pad(format_ns(t.overhead_ns), 9), i < s.tasks.size() ? s.tasks[i].exe : "");
    if (i < s.tasks.size() && !identity_text(s.tasks[i]).empty()) {
      fmt::print("  {}may run it:{}\n", pad("", 14), identity_text(s.tasks[i]));
    }
  }

  fmt::print("\ndevices ({}):\n", s.devices.size());
  for (const auto& d : s.devices) {
    fmt::print("  {}{}i2c-{} {:#04x}  {}", pad(d.name, 14), pad(d.profile, 15), d.bus, d.addr,
               d.role);
    if (!d.safe.empty()) {
      std::string safe;
      for (const auto& c : d.safe) safe += (safe.empty() ? "" : ", ") + c;
      fmt::print("; safe state {}", safe);
    }
    if (!d.latch.empty()) fmt::print("; latch {}", d.latch);
    fmt::print("\n");
  }

  fmt::print("\naccess matrix (A = may actuate, R = may read, . = denied):\n");
  std::string header = "  " + pad("", 14);
  for (const auto& d : s.devices) header += pad(d.name, std::max<size_t>(d.name.size() + 1, 4));
  fmt::print("{}\n", header);
  for (size_t t = 0; t < m.tasks.size(); ++t) {
    std::string row = "  " + pad(m.tasks[t].name, 14);
    for (size_t k = 0; k < s.devices.size(); ++k) {
      const auto& a = m.access[t];
      std::string cell;
      if (a.actuate_devices & (1u << k)) cell += "A";
      if (a.read_devices & (1u << k)) cell += "R";
      if (cell.empty()) cell = ".";
      row += pad(cell, std::max<size_t>(s.devices[k].name.size() + 1, 4));
    }
    fmt::print("{}\n", row);
  }

  if (!s.signals.empty()) {
    fmt::print("\nsignals ({}):\n", s.signals.size());
    for (const auto& sig : s.signals) fmt::print("  {}\n", sig);
  }
  fmt::print("\nrate limits ({}):\n", s.rates.size());
  for (const auto& r : s.rates) fmt::print("  {}\n", r);
  fmt::print("\ninvariants ({}, checked in this order after access and rate limits):\n",
             s.invariants.size());
  for (size_t i = 0; i < s.invariants.size(); ++i) {
    const uint32_t len = i < m.invariants.size() ? m.invariants[i].record.code_len : 0;
    fmt::print("  {}\n      ({} instructions)\n", s.invariants[i], len);
  }
  fmt::print("\nimage: {} bytes, {} bytecode instructions in all, verified by the core\n",
             out.image.size(), m.code.size());
  fmt::print("worst-case cost of one check: {} bytecode instructions\n", out.worst_case_cost);
}

nlohmann::json summary_json(const policy::CompileOutput& out) {
  const auto& m = out.model;
  const auto& s = out.summary;
  nlohmann::json j;
  j["tasks"] = nlohmann::json::array();
  for (size_t i = 0; i < m.tasks.size(); ++i) {
    const auto& t = m.tasks[i].record;
    nlohmann::json access_a = nlohmann::json::array(), access_r = nlohmann::json::array();
    for (size_t k = 0; k < s.devices.size(); ++k) {
      if (m.access[i].actuate_devices & (1u << k)) access_a.push_back(s.devices[k].name);
      if (m.access[i].read_devices & (1u << k)) access_r.push_back(s.devices[k].name);
    }
    j["tasks"].push_back({{"name", m.tasks[i].name},
                          {"exe", i < s.tasks.size() ? s.tasks[i].exe : ""},
                          {"user", i < s.tasks.size() ? s.tasks[i].user : ""},
                          {"group", i < s.tasks.size() ? s.tasks[i].group : ""},
                          {"unit", i < s.tasks.size() ? s.tasks[i].unit : ""},
                          {"cgroup", i < s.tasks.size() ? s.tasks[i].cgroup : ""},
                          {"sessions", i < s.tasks.size() ? s.tasks[i].sessions : 1},
                          {"ignore_errno", i < s.tasks.size() ? s.tasks[i].ignore_errno : 0},
                          {"period_us", t.period_us},
                          {"deadline_us", t.deadline_us},
                          {"wcet_us", t.wcet_us},
                          {"priority", t.priority},
                          {"actuations_per_job", t.actuations_per_job},
                          {"overhead_ns", t.overhead_ns},
                          {"actuates", access_a},
                          {"reads", access_r}});
  }
  j["devices"] = nlohmann::json::array();
  for (const auto& d : s.devices) {
    j["devices"].push_back({{"name", d.name},
                            {"profile", d.profile},
                            {"role", d.role},
                            {"bus", d.bus},
                            {"addr", d.addr},
                            {"safe", d.safe},
                            {"latch", d.latch}});
  }
  j["signals"] = s.signals;
  j["rate_limits"] = s.rates;
  j["invariants"] = s.invariants;
  j["image_bytes"] = out.image.size();
  j["code_instructions"] = m.code.size();
  j["worst_case_cost"] = out.worst_case_cost;
  return j;
}

}  // namespace

void register_check(CLI::App& app) {
  auto* cmd = app.add_subcommand("check", "Compile a policy, verify its image, print a summary");
  static std::string path, emit, emit_bundle;
  static bool strict = false, json = false;
  static std::optional<uint32_t> budget_factor;
  static std::vector<std::string> buses;
  cmd->add_option("POLICY", path, "policy file")->required();
  cmd->add_flag("--strict", strict, "treat warnings as errors");
  cmd->add_flag("--json", json, "print the diagnostics and the summary as JSON");
  cmd->add_option("--emit", emit, "write the verified policy image to this file");
  cmd->add_option("--emit-bundle", emit_bundle,
                  "write the policy bundle (the image and the task bindings, all that decides; "
                  "contego-monitor --bundle loads it) to this file");
  cmd->add_option("--budget-factor", budget_factor,
                  "with --emit-bundle: the over-budget hold's factor the bundle fixes (the "
                  "monitor's --budget-factor may repeat it, not change it)");
  configure_bus_option(cmd->add_option(
      "--bus", buses,
      "with --emit-bundle: N=/dev/i2c-M, the adapter of the policy's bus N the bundle fixes "
      "(repeatable; the monitor's --bus may repeat it or add others, not change it)"));
  cmd->callback([] {
    if ((budget_factor || !buses.empty()) && emit_bundle.empty()) {
      fmt::print(stderr,
                 "contego check: --budget-factor and --bus go into a bundle: give "
                 "--emit-bundle FILE\n");
      return set_exit_code(2);
    }
    auto bus_map = parse_bus_specs(buses, {});
    if (!bus_map.ok()) {
      fmt::print(stderr, "contego check: {}\n", bus_map.error());
      return set_exit_code(2);
    }
    policy::CompileOptions options;
    options.strict = strict;
    options.task_model_check = sched_closure;
    const policy::CompileOutput out = policy::compile_file(path, options);
    if (out.ok && !emit.empty()) {
      const std::string_view image(reinterpret_cast<const char*>(out.image.data()),
                                   out.image.size());
      if (!write_output(emit, image)) return set_exit_code(2);
      // The hash `contego monitor --image IMAGE --image-sha256 HASH` pins.
      fmt::print(stderr, "contego check: wrote {} ({} bytes, SHA-256 {})\n", emit, out.image.size(),
                 monitor::sha256_hex(image));
    }
    if (out.ok && !emit_bundle.empty()) {
      const std::string text = bundle::encode_bundle(
          {path, out.image, monitor::bundle_tasks(out.summary), budget_factor, *bus_map});
      // Read back as the monitor will: a bus no device is on, a relative
      // adapter path, are refused here rather than on the robot.
      if (auto back = bundle::decode_bundle(text, emit_bundle); !back.ok()) {
        fmt::print(stderr, "contego check: not written: {}\n", back.error());
        return set_exit_code(2);
      }
      if (!write_output(emit_bundle, text)) return set_exit_code(2);
      fmt::print(stderr,
                 "contego check: wrote {} ({} bytes, SHA-256 {}; image SHA-256 {}); to sign it: "
                 "minisign -Sm {}\n",
                 emit_bundle, text.size(), monitor::sha256_hex(text),
                 bundle::image_sha256(out.image), emit_bundle);
    }
    if (json) {
      nlohmann::json j;
      j["file"] = path;
      j["ok"] = out.ok;
      j["diagnostics"] = nlohmann::json::parse(policy::render_json(out.diagnostics));
      if (out.ok) j["summary"] = summary_json(out);
      fmt::print("{}\n", json_text(j, 2));
    } else {
      fmt::print(stderr, "{}", policy::render_text(out.diagnostics));
      if (out.ok) print_summary(path, out);
      size_t errors = 0, warnings = 0;
      for (const auto& d : out.diagnostics) {
        errors += d.severity == "error";
        warnings += d.severity == "warning";
      }
      if (!out.ok) {
        fmt::print(stderr, "{}: {} error{}, {} warning{}{}\n", path, errors, errors == 1 ? "" : "s",
                   warnings, warnings == 1 ? "" : "s",
                   strict && errors == 0 ? " (--strict: warnings are errors)" : "");
      } else if (warnings) {
        fmt::print(stderr, "{}: {} warning{}\n", path, warnings, warnings == 1 ? "" : "s");
      }
    }
    set_exit_code(out.ok ? 0 : 1);
  });
}

}  // namespace contego::cli
