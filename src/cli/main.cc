// contego: actuator command firewall for real-time control systems.
#include <CLI/CLI.hpp>

#include "cli/command.h"

namespace contego::cli {
namespace {
int g_exit_code = 0;
}
void set_exit_code(int code) { g_exit_code = code; }
int exit_code() { return g_exit_code; }
}  // namespace contego::cli

int main(int argc, char** argv) {
  CLI::App app{"contego: every actuation command checked against a policy"};
  app.require_subcommand(1);
  contego::cli::register_version(app);
  contego::cli::register_sched(app);
  contego::cli::register_bench(app);
  contego::cli::register_audit(app);
#ifdef CONTEGO_HAVE_POLICY
  contego::cli::register_run(app);
  contego::cli::register_monitor(app);
  contego::cli::register_test(app);
  contego::cli::register_sim(app);
  contego::cli::register_demo(app);
  contego::cli::register_check(app);
  contego::cli::register_image(app);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return contego::cli::exit_code();
}
