// The `--bus` and `--virtual-bus` arguments of `contego monitor` and
// `contego run`: which adapter serves which bus number of the policy.
#ifndef CONTEGO_CLI_BUS_ARGS_H_
#define CONTEGO_CLI_BUS_ARGS_H_

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "base/result.h"

namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace contego::cli {

// One `--bus` value: `N=PATH` (bus N of the policy is the adapter at PATH),
// or `/dev/i2c-N` alone (N read from the name). N is 0..255. Anything else
// fails with a message that quotes the value and shows the expected form.
Result<std::pair<int, std::string>> parse_bus_spec(const std::string& value);

// Every `--bus` value, plus the `--virtual-bus` numbers: a number given
// twice (as two adapters, or as real and virtual) is refused.
Result<std::map<int, std::string>> parse_bus_specs(const std::vector<std::string>& values,
                                                   const std::vector<int>& virtual_buses);

// Makes a CLI11 option take one `--bus` value per occurrence and check its
// form while parsing (so `contego --parse-only` rejects it too).
void configure_bus_option(CLI::Option* option);

// `--bus` (configured as above; `bus_note` ends its help), `--virtual-bus` and
// the tests' `--virtual-state` on `cmd`.
void add_bus_options(CLI::App* cmd, std::vector<std::string>* buses,
                     std::vector<int>* virtual_buses, std::string* virtual_state,
                     const std::string& bus_note = "");

// `--budget-factor` on `cmd`, as the Monitor takes it.
CLI::Option* add_budget_option(CLI::App* cmd, uint32_t* budget_factor);

// `--complain` and `--complain-for NAME` (complain mode) on `cmd`.
void add_complain_options(CLI::App* cmd, bool* complain, std::vector<std::string>* complain_for);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_BUS_ARGS_H_
