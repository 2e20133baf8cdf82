// `contego image dump IMAGE`: verifies a policy image with the core's
// verifier and prints every table and a disassembly of every program.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fstream>
#include <iterator>
#include <memory>
#include <vector>

#include "contego/core/checker.h"

#include "base/read_file.h"
#include "cli/command.h"
#include "image/image_model.h"

namespace contego::cli {

void register_image(CLI::App& app) {
  auto* image = app.add_subcommand("image", "Inspect policy images");
  image->require_subcommand(1);
  auto* dump = image->add_subcommand("dump", "Verify an image and print its tables and programs");
  static std::string path;
  dump->add_option("IMAGE", path, "policy image file (from `contego check --emit`)")->required();
  dump->callback([] {
    Result<std::string> text = read_input_file(path);
    if (!text) {
      fmt::print(stderr, "contego image dump: {}\n", text.error());
      set_exit_code(2);
      return;
    }
    const std::vector<uint8_t> bytes(text->begin(), text->end());
    auto checker = std::make_unique<core::Checker>();
    const core::LoadResult r = checker->load(bytes.data(), static_cast<uint32_t>(bytes.size()));
    if (r.status != core::LoadStatus::kOk) {
      fmt::print(stderr, "{}: refused by the verifier: {} (section {}, record {})\n", path,
                 core::load_status_name(r.status), r.section, r.index);
      set_exit_code(1);
      return;
    }
    auto model = image::deserialize(bytes);
    if (!model) {
      fmt::print(stderr, "{}: {}\n", path, model.error());
      set_exit_code(1);
      return;
    }
    fmt::print("{}", image::dump(*model));
    fmt::print("worst-case cost of one check: {} bytecode instructions\n",
               checker->worst_case_cost());
  });
}

}  // namespace contego::cli
