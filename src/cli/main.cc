// contego: actuator command firewall for real-time control systems.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fmt/core.h>
#include <string>

#include "cli/command.h"

namespace contego::cli {
namespace {
// `contego --parse-only CMD ...`: every subcommand parses and checks its
// arguments as usual (conversions, validators, required options), then
// prints what it would run instead of running it. tests/docs uses it to
// keep the command lines of the documentation in step with the CLI.
// The subcommands' own callbacks stay in place (they own the variables their
// options write into); this one runs first, after every check, and exits.
void make_parse_only(CLI::App& app, const std::string& path) {
  for (CLI::App* sub : app.get_subcommands({})) {
    const std::string name = path + " " + sub->get_name();
    sub->parse_complete_callback([name] {
      fmt::print("parse-only: contego{}: ok\n", name);
      std::fflush(stdout);
      std::_Exit(0);
    });
    make_parse_only(*sub, name);
  }
}
}  // namespace
}  // namespace contego::cli

int main(int argc, char** argv) {
  contego::cli::set_command_line(argc, argv);
  CLI::App app{"contego: every actuation command checked against a policy"};
  app.require_subcommand(1);
  app.set_version_flag("--version", contego::cli::version_line());
  contego::cli::register_version(app);
  contego::cli::register_doctor(app);
  contego::cli::register_sched(app);
  contego::cli::register_bench(app);
  contego::cli::register_audit(app);
#ifdef CONTEGO_HAVE_POLICY
  contego::cli::register_run(app);
  contego::cli::register_monitor(app);
  contego::cli::register_reset(app);
  contego::cli::register_reload(app);
  contego::cli::register_status(app);
  contego::cli::register_kmod(app);
  contego::cli::register_test(app);
  contego::cli::register_sim(app);
  contego::cli::register_demo(app);
  contego::cli::register_check(app);
  contego::cli::register_image(app);
  contego::cli::register_replay(app);
  contego::cli::register_policy(app);
#endif
  if (argc > 1 && std::strcmp(argv[1], "--parse-only") == 0) {
    contego::cli::make_parse_only(app, "");
    argv[1] = argv[0];
    --argc;
    ++argv;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return contego::cli::exit_code();
}
