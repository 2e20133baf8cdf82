#include "cli/install_paths.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <system_error>

namespace contego::cli {
namespace {
namespace fs = std::filesystem;

fs::path executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path(".") : exe.parent_path();
}

// key=value lines of the build tree's marker file; empty when there is none.
std::map<std::string, std::string> build_tree_paths(const fs::path& dir) {
  std::map<std::string, std::string> out;
  std::ifstream in(dir / "contego-build-tree.paths");
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq != std::string::npos) out[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return out;
}

std::string normal(const fs::path& p) { return p.lexically_normal().string(); }

InstallPaths compute() {
  const fs::path dir = executable_dir();
  auto tree = build_tree_paths(dir);
  if (!tree.empty()) return {tree["data"], tree["preload"], tree["bench_task"]};
  return {normal(dir / CONTEGO_BIN_TO_DATA),
          normal(dir / CONTEGO_BIN_TO_LIB / "libcontego_preload.so"),
          normal(dir / CONTEGO_BIN_TO_LIBEXEC / "contego-bench-task")};
}
}  // namespace

const InstallPaths& install_paths() {
  static const InstallPaths paths = compute();
  return paths;
}

std::string find_data_file(const std::string& relative) {
  if (fs::exists(relative)) return relative;
  const fs::path installed = fs::path(install_paths().data_dir) / relative;
  if (fs::exists(installed)) return installed.string();
  return relative;
}

}  // namespace contego::cli
