#include "cli/bus_args.h"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <set>

#include "base/bus_number.h"

namespace contego::cli {

Result<std::pair<int, std::string>> parse_bus_spec(const std::string& value) {
  const std::string expected = "expected N=PATH (e.g. 1=/dev/i2c-1) or /dev/i2c-N";
  const size_t eq = value.find('=');
  if (eq == std::string::npos) {
    const std::string prefix = "/dev/i2c-";
    if (value.rfind(prefix, 0) == 0) {
      const int n = parse_bus_number(value.substr(prefix.size()));
      if (n >= 0) return std::make_pair(n, value);
    }
    return make_error(fmt::format("--bus '{}': {}", value, expected));
  }
  const int n = parse_bus_number(value.substr(0, eq));
  if (n < 0) {
    return make_error(fmt::format("--bus '{}': the bus number '{}' is not 0..255; {}", value,
                                  value.substr(0, eq), expected));
  }
  const std::string path = value.substr(eq + 1);
  if (path.empty())
    return make_error(fmt::format("--bus '{}': no device path; {}", value, expected));
  return std::make_pair(n, path);
}

Result<std::map<int, std::string>> parse_bus_specs(const std::vector<std::string>& values,
                                                   const std::vector<int>& virtual_buses) {
  std::map<int, std::string> out;
  for (const auto& v : values) {
    auto spec = parse_bus_spec(v);
    if (!spec.ok()) return make_error(spec.error());
    const auto [n, path] = *spec;
    if (auto it = out.find(n); it != out.end()) {
      return make_error(fmt::format("--bus '{}': bus {} is already {}", v, n, it->second));
    }
    out[n] = path;
  }
  std::set<int> seen;
  for (int n : virtual_buses) {
    if (n < 0 || n > 255) return make_error(fmt::format("--virtual-bus {}: not 0..255", n));
    if (out.count(n) != 0) {
      return make_error(
          fmt::format("--virtual-bus {}: bus {} is already the adapter {}", n, n, out[n]));
    }
    if (!seen.insert(n).second) return make_error(fmt::format("--virtual-bus {}: given twice", n));
  }
  return out;
}

void configure_bus_option(CLI::Option* option) {
  option->allow_extra_args(false)->type_name("N=PATH")->check(CLI::Validator(
      [](std::string& value) {
        auto spec = parse_bus_spec(value);
        return spec.ok() ? std::string() : spec.error();
      },
      "N=PATH"));
}

void add_bus_options(CLI::App* cmd, std::vector<std::string>* buses,
                     std::vector<int>* virtual_buses, std::string* virtual_state,
                     const std::string& bus_note) {
  configure_bus_option(cmd->add_option(
      "--bus", *buses,
      "N=PATH: bus N of the policy is the adapter at PATH (e.g. 1=/dev/i2c-1; /dev/i2c-N alone "
      "means N=/dev/i2c-N); once per bus" +
          bus_note));
  cmd->add_option("--virtual-bus", *virtual_buses,
                  "N: bus N is a virtual bus with the built-in device models (PCA9685 0x40, "
                  "GoPiGo2 0x08, line follower 0x06); once per bus")
      ->allow_extra_args(false);
  cmd->add_option("--virtual-state", *virtual_state,
                  "tests: write the virtual buses' device state to this file at exit")
      ->group("");
}

CLI::Option* add_budget_option(CLI::App* cmd, uint32_t* budget_factor) {
  return cmd
      ->add_option("--budget-factor", *budget_factor,
                   "hold a task's transfers to the end of its period once it has sent more than "
                   "this many times its declared actuations in one job (0 = never)")
      ->capture_default_str();
}

void add_complain_options(CLI::App* cmd, bool* complain, std::vector<std::string>* complain_for) {
  cmd->add_flag("--complain", *complain,
                "complain mode: every command acts as the program sent it and the audit log "
                "records the verdict the policy would have given (to fit a policy; never on an "
                "unattended robot)");
  cmd->add_option("--complain-for", *complain_for,
                  "NAME: complain mode for this task or device only, the rest enforced; once per "
                  "name")
      ->allow_extra_args(false);
}

}  // namespace contego::cli
