// `contego sim` and `contego demo` as a user runs them: the files they say
// they write are there, the demo is quick, bad scenario files are refused
// with the file and line.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <iterator>
#include <set>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include "base/test_temp.h"

namespace {

namespace fs = std::filesystem;

std::string source(const std::string& rel) { return std::string(CONTEGO_SOURCE_DIR) + "/" + rel; }

struct Ran {
  int exit_code;
  std::string output;  // stdout and stderr
};

Ran contego(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(CONTEGO_BINARY) + " " + args + " > " + log.string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream f(log);
  std::stringstream ss;
  ss << f.rdbuf();
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str()};
}

bool non_empty(const fs::path& p) { return fs::exists(p) && fs::file_size(p) > 0; }

class SimCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Unique per run: two test runs at once must not share (or clear) a folder.
    std::string dir;
    ASSERT_NO_FATAL_FAILURE(contego::test_support::make_temp_dir(
        std::string("contego-sim-cli-") +
            ::testing::UnitTest::GetInstance()->current_test_info()->name(),
        &dir));
    dir_ = dir;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// The demo's duration is reported, not asserted: these machines are shared
// and a sanitizer build under load may take minutes.
TEST_F(SimCliTest, DemoWritesThePapersFigures) {
  const auto start = std::chrono::steady_clock::now();
  const Ran r = contego("demo --out " + (dir_ / "demo").string(), dir_ / "log");
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.output;
  RecordProperty("demo_seconds", std::to_string(secs));
  for (const char* fig : {"fig1", "fig4a", "fig4b"}) {
    for (const char* ext : {".png", ".svg"}) {
      const fs::path p = dir_ / "demo" / (std::string(fig) + ext);
      EXPECT_TRUE(non_empty(p)) << p;
      EXPECT_NE(r.output.find(p.string()), std::string::npos) << "the demo names " << p;
    }
    EXPECT_TRUE(non_empty(dir_ / "demo" / (std::string(fig) + "-protected.csv")));
  }
  EXPECT_NE(r.output.find("distance (cm)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("objects_handled"), std::string::npos) << r.output;

  // The figures explain themselves to a reader of the paper (issue 39): Fig. 1
  // says why its open/close labels are the paper's reversed, on one y range
  // for both panels; Fig. 4b says the protected run's dip is the track's bend.
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string fig1 = slurp(dir_ / "demo" / "fig1.gp");
  EXPECT_NE(fig1.find("the paper's text swaps the two names"), std::string::npos) << fig1;
  std::set<std::string> yranges;
  for (size_t at = fig1.find("set yrange [0:"); at != std::string::npos;
       at = fig1.find("set yrange [0:", at + 1)) {
    yranges.insert(fig1.substr(at, fig1.find('\n', at) - at));
  }
  EXPECT_EQ(yranges.size(), 1u) << fig1;
  const std::string fig4b = slurp(dir_ / "demo" / "fig4b.gp");
  EXPECT_NE(fig4b.find("the track's bend"), std::string::npos) << fig4b;
  EXPECT_NE(slurp(dir_ / "demo" / "fig4b.svg").find("bend"), std::string::npos);
}

TEST_F(SimCliTest, SimWritesTracesFigureAndSummary) {
  const Ran r = contego(
      "sim " + source("scenarios/tank_false_alarm.scn") + " --out " + dir_.string(), dir_ / "log");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* label : {"baseline", "unprotected", "protected"}) {
    EXPECT_TRUE(non_empty(dir_ / (std::string("tank_false_alarm-") + label + ".csv")));
    EXPECT_TRUE(non_empty(dir_ / (std::string("tank_false_alarm-") + label + "-ops.csv")));
  }
  EXPECT_TRUE(non_empty(dir_ / "tank_false_alarm.svg"));
  EXPECT_TRUE(non_empty(dir_ / "tank_false_alarm.png"));
  EXPECT_NE(r.output.find("false_alarm_time"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("first violation"), std::string::npos) << r.output;
}

TEST_F(SimCliTest, BadScenarioIsRefusedWithFileAndLine) {
  const fs::path bad = dir_ / "bad.scn";
  std::ofstream(bad) << "platform rover\nduration ten seconds\n";
  const Ran r = contego("sim " + bad.string() + " --out " + dir_.string(), dir_ / "log");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find(bad.string() + ":2:"), std::string::npos) << r.output;
}

TEST_F(SimCliTest, MissingScenarioFileIsNamed) {
  const Ran r = contego("sim " + (dir_ / "nope.scn").string(), dir_ / "log");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("nope.scn: cannot open"), std::string::npos) << r.output;
}

}  // namespace
