// Real-time mode, end to end: `contego sim --realtime` runs the line-follower
// loop as a separate, unmodified Python program that talks to /dev/i2c-1
// with ioctl/read/write, under the seccomp supervisor, while the rover plant
// advances in real time on the monitor's virtual bus. The program carries a
// spoofing logic bomb from 3 s to 7 s (the plant's clock starts with the
// program's first bus transfer). Same qualitative outcome as in
// virtual time: without protection the rover stands during the attack, with
// protection it keeps driving.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "base/test_temp.h"

namespace {

std::string source(const std::string& rel) { return std::string(CONTEGO_SOURCE_DIR) + "/" + rel; }

// distance_cm at time t from a trace CSV.
double distance_at(const std::string& path, double t) {
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);
  std::vector<std::string> head;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) head.push_back(c);
  size_t col = 0;
  while (col < head.size() && head[col] != "distance_cm") ++col;
  EXPECT_LT(col, head.size()) << path;
  double last = 0;
  while (std::getline(f, line)) {
    std::stringstream ls(line);
    std::vector<double> v;
    for (std::string c; std::getline(ls, c, ',');) v.push_back(std::stod(c));
    if (v.size() <= col) continue;
    last = v[col];
    if (v[0] >= t) return v[col];
  }
  return last;
}

TEST(SimRealtimeTest, SeparateControllerProgramUnderContegoKeepsTheRoverDriving) {
  // A folder of its own: two test runs at once (two checkouts) must not
  // share an audit log, whose lock would refuse the second monitor.
  std::string out_dir;
  ASSERT_NO_FATAL_FAILURE(contego::test_support::make_temp_dir("contego-sim-realtime", &out_dir));
  const std::filesystem::path out = out_dir;
  const std::string cmd = std::string(CONTEGO_BINARY) + " sim " +
                          source("scenarios/rover_rt_spoof.scn") + " --realtime --no-plots --out " +
                          out.string() + " -- " + CONTEGO_PYTHON3 + " " +
                          source("scenarios/programs/line_follower.py") +
                          " --duration 10 --attack spoof --attack-from 3 --attack-to 7 > " +
                          (out.string() + ".log") + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream log(out.string() + ".log");
  std::stringstream ls;
  ls << log.rdbuf();
  ASSERT_TRUE(WIFEXITED(rc) && WEXITSTATUS(rc) == 0) << ls.str();

  const std::string off = (out / "rover_rt_spoof-rt-unprotected.csv").string();
  const std::string on = (out / "rover_rt_spoof-rt-protected.csv").string();
  // Before the attack both drive (about 9 cm/s).
  EXPECT_GT(distance_at(off, 3.0), 12.0);
  EXPECT_GT(distance_at(on, 3.0), 12.0);
  // During it the unprotected rover stands, the protected one keeps going.
  EXPECT_LT(distance_at(off, 7.0) - distance_at(off, 3.6), 3.0);
  EXPECT_GT(distance_at(on, 7.0) - distance_at(on, 3.6), 15.0);
  std::filesystem::remove_all(out);
  std::filesystem::remove(out.string() + ".log");
}

}  // namespace
