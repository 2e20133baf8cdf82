#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "contego/core/image.h"

#include "cli/command.h"

namespace contego::cli {

void register_version(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("version", "Print the version and the policy image format version");
  cmd->callback([] { fmt::print("{}\n", version_line()); });
}

std::string version_line() {
  return fmt::format("contego {} (policy image format {}.{})", CONTEGO_VERSION,
                     core::kImageVersionMajor, core::kImageVersionMinor);
}

}  // namespace contego::cli
