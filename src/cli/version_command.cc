#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "contego/core/image.h"

#include "cli/command.h"

namespace contego::cli {

void register_version(CLI::App& app) {
  auto* cmd =
      app.add_subcommand("version", "Print the version and the policy image format version");
  cmd->callback([] {
    fmt::print("contego 0.1.0 (policy image format {}.{})\n", core::kImageVersionMajor,
               core::kImageVersionMinor);
  });
}

}  // namespace contego::cli
