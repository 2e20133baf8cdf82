// The options `contego monitor` and `contego run` share, copied into the
// trusted side's SetupOptions: the audit log, the buses, the budget factor
// and whether a degraded start is allowed.
#ifndef CONTEGO_CLI_SETUP_ARGS_H_
#define CONTEGO_CLI_SETUP_ARGS_H_

#include "base/result.h"
#include "cli/bus_args.h"
#include "cli/trusted_setup.h"

namespace contego::cli {

// `Args` has audit, audit_options, buses, virtual_buses, budget_factor and
// allow_degraded. Fails (with parse_bus_specs's message) on a bad `--bus`.
template <typename Args>
Status apply_setup_args(const Args& args, monitor::SetupOptions& so) {
  so.audit = args.audit;
  so.audit_options = args.audit_options;
  auto buses = parse_bus_specs(args.buses, args.virtual_buses);
  if (!buses.ok()) return make_error(buses.error());
  so.real_buses = *buses;
  so.virtual_buses = args.virtual_buses;
  so.budget_factor = args.budget_factor;
  if constexpr (requires { args.budget_factor_given; }) {
    so.budget_factor_given = args.budget_factor_given;
  }
  so.allow_degraded = args.allow_degraded;
  so.complain = args.complain;
  so.complain_for = args.complain_for;
  return {};
}

}  // namespace contego::cli

#endif  // CONTEGO_CLI_SETUP_ARGS_H_
