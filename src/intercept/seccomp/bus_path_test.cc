#include "intercept/seccomp/bus_path.h"

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <string>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>

#include "base/test_temp.h"

namespace contego::intercept::seccomp {
namespace {

pid_t tid() { return static_cast<pid_t>(syscall(SYS_gettid)); }

TEST(BusPath, OneParserOfNodeNames) {
  EXPECT_EQ(bus_number("/dev/i2c-1"), 1);
  EXPECT_EQ(bus_number("/dev/i2c/12"), 12);
  EXPECT_EQ(bus_number("/dev/i2c-256"), -1);
  EXPECT_EQ(bus_number("/dev/i2c-1x"), -1);
  EXPECT_EQ(bus_number("/dev/i2c-"), -1);
  EXPECT_EQ(lexical_normalise("/a/./b//../../dev/i2c-1"), "/dev/i2c-1");
  EXPECT_EQ(lexical_normalise("/../.."), "/");
}

TEST(BusPath, NodesWithoutAFileAreKnownByName) {
  EXPECT_EQ(resolve_bus_path(tid(), AT_FDCWD, "/dev/../dev/i2c-3", 0, false).bus, 3);
  EXPECT_EQ(resolve_bus_path(tid(), AT_FDCWD, "/etc/passwd", 0, false).bus, -1);
  EXPECT_EQ(resolve_bus_path(tid(), AT_FDCWD, "/dev/i2c-3", 0x1000, false).refuse, EINVAL);
}

// A character node of the i2c-dev major in a scratch directory stands for
// /dev/i2c-7 (this host has no i2c adapter): every other name of it is a bus.
class BusNode : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("contego-bus-path", &dir));
    if (mknod((dir + "/node").c_str(), S_IFCHR | 0600, makedev(89, 7)) != 0) {
      GTEST_SKIP() << "cannot make a character node here (needs CAP_MKNOD)";
    }
    ASSERT_EQ(symlink((dir + "/node").c_str(), (dir + "/link").c_str()), 0);
    ASSERT_EQ(mkdir((dir + "/sub").c_str(), 0700), 0);
    char cwd[4096];
    ASSERT_NE(getcwd(cwd, sizeof cwd), nullptr);
    old_cwd = cwd;
  }
  void TearDown() override {
    if (!old_cwd.empty()) (void)!chdir(old_cwd.c_str());
    unlink((dir + "/node").c_str());
    unlink((dir + "/link").c_str());
    rmdir((dir + "/sub").c_str());
    rmdir(dir.c_str());
  }
  int bus(const std::string& path, int dirfd = AT_FDCWD, uint64_t resolve = 0,
          bool nofollow = false) {
    return resolve_bus_path(tid(), dirfd, path, resolve, nofollow).bus;
  }
  std::string dir, old_cwd;
};

TEST_F(BusNode, TheNodeByAnyPathIsTheBusItsMinorNames) {
  EXPECT_EQ(bus(dir + "/node"), 7);
  EXPECT_EQ(bus(dir + "/sub/../node"), 7);
  EXPECT_EQ(bus(dir + "/link"), 7);
  EXPECT_EQ(bus(dir + "/link", AT_FDCWD, 0, true), -1);  // O_NOFOLLOW: the kernel refuses it
  ASSERT_EQ(chdir(dir.c_str()), 0);
  EXPECT_EQ(bus("node"), 7);
  EXPECT_EQ(bus("/proc/self/cwd/node"), 7);
  EXPECT_EQ(bus("/proc/thread-self/cwd/node"), 7);
  EXPECT_EQ(bus("/proc/" + std::to_string(getpid()) + "/root" + dir + "/node"), 7);
  EXPECT_EQ(bus("../" + dir.substr(dir.rfind('/') + 1) + "/link"), 7);
}

TEST_F(BusNode, Openat2InRootResolvesAgainstTheDirectory) {
  const int d = open(dir.c_str(), O_PATH | O_DIRECTORY);
  ASSERT_GE(d, 0);
  EXPECT_EQ(bus("/node", d, 0x10), 7);        // RESOLVE_IN_ROOT
  EXPECT_EQ(bus("/../../node", d, 0x10), 7);  // `..` stops at that root
  EXPECT_EQ(bus("node", d), 7);
  close(d);
}

}  // namespace
}  // namespace contego::intercept::seccomp
