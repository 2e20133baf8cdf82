// contego-monitor: the trusted daemon, sole owner of the buses. It loads a
// policy bundle or a pinned image, never a policy source, and links only
// what deciding and acting need (cli/monitor_daemon.h); `contego monitor`
// compiles a policy and runs it.
#include <CLI/CLI.hpp>

#include "cli/command.h"
#include "cli/monitor_daemon.h"

int main(int argc, char** argv) {
  contego::cli::set_command_line(argc, argv);
  CLI::App app{"contego-monitor: the trusted daemon that checks every actuation command"};
  app.set_version_flag("--version", contego::cli::version_line());
  contego::cli::MonitorArgs args;
  contego::cli::add_monitor_options(&app, &args, /*daemon=*/true);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return contego::cli::run_monitor_daemon(args);
}
