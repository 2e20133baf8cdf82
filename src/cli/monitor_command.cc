// `contego monitor`: the trusted daemon, started the way the tool's users
// know. It parses contego-monitor's options, compiles --policy here (into a
// bundle: the image and the task bindings) and executes contego-monitor with
// that bundle on a sealed memory file, so that the process that decides, from
// then on, is the small binary that links no compiler (docs/deployment.md).
// The PID stays the same: a unit's main process and a test's child are the
// daemon.
#include <fcntl.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstring>
#include <fmt/core.h>
#include <memory>
#include <string>
#include <sys/mman.h>
#include <vector>

#include "bundle/bundle.h"
#include "cli/command.h"
#include "cli/monitor_daemon.h"
#include "cli/policy_load.h"

namespace contego::cli {
namespace {

// A sealed memory file holding `text`, inherited across exec (no CLOEXEC).
int sealed_memfd(const std::string& text) {
  const int fd = ::memfd_create("contego-bundle", MFD_ALLOW_SEALING);
  if (fd < 0) return -1;
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      return -1;
    }
    done += static_cast<size_t>(n);
  }
  if (::fcntl(fd, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_WRITE | F_SEAL_SEAL) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

int exec_daemon(const MonitorArgs& args) {
  if (const std::string e = monitor_usage_error(args, /*daemon=*/false); !e.empty()) {
    fmt::print(stderr, "contego monitor: {}\n", e);
    return 2;
  }
  std::vector<std::string> argv{daemon_path()};
  if (!args.policy.empty()) {
    monitor::SetupOptions so;
    so.policy = args.policy;
    so.image = args.image;
    so.image_sha256 = args.image_sha256;
    auto loaded = monitor::load_policy(so);
    if (!loaded.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", loaded.error());
      return 2;
    }
    const int fd = sealed_memfd(bundle::encode_bundle(monitor::bundle_of(*loaded, args.policy)));
    if (fd < 0) {
      fmt::print(stderr, "contego monitor: cannot hand the compiled policy over: {}\n",
                 std::strerror(errno));
      return 2;
    }
    argv.insert(argv.end(), {"--bundle-fd", std::to_string(fd)});
  }
  for (const std::string& a : arguments_after("monitor")) argv.push_back(a);
  std::vector<char*> raw;
  for (std::string& a : argv) raw.push_back(a.data());
  raw.push_back(nullptr);
  ::execv(raw[0], raw.data());
  fmt::print(stderr, "contego monitor: cannot start {}: {}\n", argv[0], std::strerror(errno));
  return 2;
}

}  // namespace

void register_monitor(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "monitor", "The trusted-side daemon: sole owner of the buses (runs contego-monitor)");
  auto args = std::make_shared<MonitorArgs>();
  add_monitor_options(cmd, args.get(), /*daemon=*/false);
  cmd->callback([args] { set_exit_code(exec_daemon(*args)); });
}

}  // namespace contego::cli
