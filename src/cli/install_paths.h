// Where contego finds its data (example policies, scenarios), the preload
// library and the bench task program, decided at run time from the
// executable's own location, so that no path of the source or build tree is
// baked into the binary:
//   - in a build tree, a file `contego-build-tree.paths` beside the
//     executable (written by CMake, never installed) names them;
//   - installed, they are found relative to the executable: the relative
//     paths between the install directories (GNUInstallDirs) are compiled in.
#ifndef CONTEGO_CLI_INSTALL_PATHS_H_
#define CONTEGO_CLI_INSTALL_PATHS_H_

#include <string>

namespace contego::cli {

struct InstallPaths {
  std::string data_dir;    // holds policies/ and scenarios/
  std::string preload;     // libcontego_preload.so
  std::string bench_task;  // contego-bench-task
};

// Computed once, on first use.
const InstallPaths& install_paths();

// `relative` (e.g. "scenarios/rover_spoof.scn") in the working directory if
// it is there, else in the data directory; returned unchanged when neither
// has it (the caller's error then names it).
std::string find_data_file(const std::string& relative);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_INSTALL_PATHS_H_
