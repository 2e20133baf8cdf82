// Each `contego` subcommand lives in its own file and registers itself with
// the CLI11 app through one function declared here. main.cc calls them all.
#ifndef CONTEGO_CLI_COMMAND_H_
#define CONTEGO_CLI_COMMAND_H_

#include <string>
#include <string_view>
#include <vector>

namespace CLI {
class App;
}

namespace contego::cli {

// Every register_* adds one subcommand whose callback sets the process exit
// code through set_exit_code().
void register_version(CLI::App& app);
void register_doctor(CLI::App& app);
void register_sched(CLI::App& app);
void register_bench(CLI::App& app);
void register_audit(CLI::App& app);
// run and monitor need the policy compiler (built when src/policy is present).
void register_run(CLI::App& app);
void register_monitor(CLI::App& app);
void register_reset(CLI::App& app);
void register_reload(CLI::App& app);
void register_status(CLI::App& app);
void register_kmod(CLI::App& app);
void register_test(CLI::App& app);
// sim needs the policy compiler too.
void register_sim(CLI::App& app);
void register_demo(CLI::App& app);
// check and image need the policy compiler too.
void register_check(CLI::App& app);
void register_image(CLI::App& app);
// replay and policy (generate) read audit logs and compile policies.
void register_replay(CLI::App& app);
void register_policy(CLI::App& app);

// "contego X.Y.Z (policy image format M.N)": `contego version`, `contego --version`.
std::string version_line();

void set_exit_code(int code);
int exit_code();

// "SIGTERM", "SIGINT", ... ("signal N" for one without a name).
std::string signal_name(int sig);

// main() keeps its arguments; a subcommand that hands its own arguments to
// another program takes those after its name (the first argument equal to
// `word`).
void set_command_line(int argc, char** argv);
std::vector<std::string> arguments_after(std::string_view word);

// A program installed beside this executable (installed, and in the build
// tree): contego-monitor for `contego monitor`, contego for contego-monitor.
std::string sibling_path(const char* name);
inline std::string daemon_path() { return sibling_path("contego-monitor"); }

}  // namespace contego::cli

#endif  // CONTEGO_CLI_COMMAND_H_
