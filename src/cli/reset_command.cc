// `contego reset DEVICE [--socket PATH]`: asks the running monitor to clear
// the latch of DEVICE (its name in the policy). Granted to root and to the
// monitor's own uid; the monitor audits every request (`reset`,
// `reset-refused`). Exit status 0 when the latch is clear, 1 when the
// monitor refused, 2 when it cannot be reached.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "cli/command.h"
#include "gate/operator.h"

namespace contego::cli {

void register_reset(CLI::App& app) {
  struct Args {
    std::string device, socket = "/run/contego/monitor.sock";
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "reset", "Clear a latched device in the running monitor (root or the monitor's uid)");
  cmd->add_option("DEVICE", args->device, "the device's name in the policy")->required();
  cmd->add_option("--socket", args->socket, "the monitor's Unix socket")->capture_default_str();
  cmd->callback([args] {
    const Result<bool> r = gate::request_reset(args->socket, args->device);
    if (!r.ok()) {
      fmt::print(stderr, "contego reset: {}\n", r.error());
      const bool unreachable = r.error().find("cannot reach") != std::string::npos;
      return set_exit_code(unreachable ? 2 : 1);
    }
    fmt::print("contego reset: {} {}\n", args->device,
               *r ? "was latched; its latch is cleared" : "was not latched");
  });
}

}  // namespace contego::cli
