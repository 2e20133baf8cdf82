// What every command of contego and contego-monitor shares: the exit code,
// signal names, the command line and where the daemon is.
#include <string.h>
#include <unistd.h>

#include <climits>
#include <string>
#include <string_view>
#include <vector>

#include "cli/command.h"

namespace contego::cli {
namespace {
int g_exit_code = 0;
std::vector<std::string> g_arguments;
}  // namespace

void set_exit_code(int code) { g_exit_code = code; }
int exit_code() { return g_exit_code; }

std::string signal_name(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev != nullptr ? std::string("SIG") + abbrev : "signal " + std::to_string(sig);
}

void set_command_line(int argc, char** argv) { g_arguments.assign(argv, argv + argc); }

std::vector<std::string> arguments_after(std::string_view word) {
  for (size_t i = 1; i < g_arguments.size(); ++i) {
    if (g_arguments[i] == word)
      return {g_arguments.begin() + static_cast<long>(i) + 1, g_arguments.end()};
  }
  return {};
}

std::string sibling_path(const char* name) {
  char self[PATH_MAX];
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  if (n <= 0) return name;  // the caller's exec or stat then fails and says so
  std::string dir(self, static_cast<size_t>(n));
  dir.resize(dir.rfind('/') + 1);
  return dir + name;
}

}  // namespace contego::cli
