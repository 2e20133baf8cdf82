#include "monitor/peer_identity.h"

#include <unistd.h>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>

namespace contego::monitor {
namespace {

TaskIdentity with(std::string exe = "", std::string user = "", std::string group = "",
                  std::string cgroup = "") {
  TaskIdentity id;
  id.exe = std::move(exe);
  id.user = std::move(user);
  id.group = std::move(group);
  id.cgroup = std::move(cgroup);
  return id;
}

TEST(PeerIdentity, StatusGivesEffectiveIdsParentAndGroups) {
  PeerFacts f;
  parse_status(
      "Name:\tx\nPPid:\t42\nUid:\t1000\t1001\t1001\t1001\nGid:\t50\t51\t51\t51\n"
      "Groups:\t4 27 100 \n",
      &f);
  EXPECT_EQ(f.ppid, 42);
  EXPECT_EQ(f.uid, 1001u);
  EXPECT_EQ(f.gid, 51u);
  EXPECT_EQ(f.groups, (std::vector<gid_t>{4, 27, 100}));
}

TEST(PeerIdentity, CgroupIsTheUnifiedLineElseSystemds) {
  EXPECT_EQ(unified_cgroup("0::/system.slice/gripper.service\n"), "/system.slice/gripper.service");
  EXPECT_EQ(unified_cgroup("12:cpu:/x\n1:name=systemd:/user.slice/a.scope\n"),
            "/user.slice/a.scope");
}

TEST(PeerIdentity, NumericAndNamedUsersResolveUnknownOnesFail) {
  auto b = resolve_binding("t", with("", "1234", "0"));
  ASSERT_TRUE(b.ok()) << b.error();
  EXPECT_EQ(*b->uid, 1234u);
  EXPECT_EQ(*b->gid, 0u);
  EXPECT_TRUE(resolve_binding("t", with("", "root")).ok());
  // Cannot be met here: the task is refused to everyone (fail closed), the others run.
  auto bad = resolve_binding("gripper", with("", "no-such-user-contego"));
  ASSERT_TRUE(bad.ok());
  EXPECT_NE(bad->unresolved.find("gripper"), std::string::npos);
  EXPECT_NE(bad->unresolved.find("no-such-user-contego"), std::string::npos);
  EXPECT_FALSE(binding_mismatch("gripper", *bad, PeerFacts{}).ok());
  EXPECT_FALSE(resolve_binding("t", with("relative/path")).ok());
  auto missing = resolve_binding("t", with("/no/such/exe"));
  ASSERT_TRUE(missing.ok());
  EXPECT_NE(missing->unresolved, "");
  EXPECT_FALSE(resolve_binding("t", with("", "", "", "system.slice")).ok());
  EXPECT_FALSE(resolve_binding("t", with()).value().binds());
}

PeerFacts facts(uid_t uid, gid_t gid, std::string cgroup) {
  PeerFacts f;
  f.uid = uid;
  f.gid = gid;
  f.cgroup = std::move(cgroup);
  return f;
}

TEST(PeerIdentity, MismatchNamesWhatDiffers) {
  TaskBinding b;
  b.uid = 1000;
  EXPECT_TRUE(binding_mismatch("arm_init", b, facts(1000, 1, "/")).ok());
  EXPECT_NE(binding_mismatch("arm_init", b, facts(1001, 1, "/")).error().find("uid 1000"),
            std::string::npos);
  TaskBinding g;
  g.gid = 27;
  PeerFacts in_group = facts(5, 5, "/");
  in_group.groups = {27};
  EXPECT_TRUE(binding_mismatch("t", g, in_group).ok());
  EXPECT_FALSE(binding_mismatch("t", g, facts(5, 5, "/")).ok());
  TaskBinding c;
  c.cgroup = "/system.slice/gripper.service";
  EXPECT_TRUE(binding_mismatch("t", c, facts(0, 0, "/system.slice/gripper.service")).ok());
  EXPECT_TRUE(binding_mismatch("t", c, facts(0, 0, "/system.slice/gripper.service/sub")).ok());
  EXPECT_FALSE(binding_mismatch("t", c, facts(0, 0, "/system.slice/gripper.service2")).ok());
  TaskBinding u;
  u.unit = "gripper.service";
  EXPECT_TRUE(binding_mismatch("t", u, facts(0, 0, "/system.slice/gripper.service")).ok());
  EXPECT_FALSE(binding_mismatch("t", u, facts(0, 0, "/system.slice/arm.service")).ok());
}

TEST(PeerIdentity, ExeComparedByDeviceAndInodeOfThePinnedProcess) {
  auto self = resolve_binding("t", with("/proc/self/exe"));
  // /proc/self/exe is a link: resolved at start to this test binary.
  ASSERT_TRUE(self.ok()) << self.error();
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, getpid(), 0));
  ASSERT_GE(pidfd, 0);
  auto me = process_facts(pidfd, getpid());
  close(pidfd);
  ASSERT_TRUE(me.ok()) << me.error();
  EXPECT_TRUE(binding_mismatch("t", *self, *me).ok());
  auto sh = resolve_binding("t", with("/bin/sh"));
  ASSERT_TRUE(sh.ok());
  const std::string why = binding_mismatch("t", *sh, *me).error();
  EXPECT_NE(why.find("/bin/sh"), std::string::npos) << why;
}

TEST(PeerIdentity, AProcessOfAnotherUidIsAliveToANonRootMonitor) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to play two uids";
  int ready[2], started[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(started), 0);
  const pid_t other = fork();
  if (other == 0) {
    close(ready[1]);
    if (setgid(65534) != 0 || setuid(65534) != 0) _exit(1);
    (void)!write(started[1], "x", 1);  // its uid is set
    char c;
    (void)!read(ready[0], &c, 1);  // lives until the pipe closes
    _exit(0);
  }
  char c;
  ASSERT_EQ(read(started[0], &c, 1), 1);
  close(started[0]);
  close(started[1]);
  const pid_t monitor = fork();
  if (monitor == 0) {
    // A monitor of uid 1 (not root, not the peer's uid) reads the peer's facts.
    if (setgid(1) != 0 || setuid(1) != 0) _exit(2);
    const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, other, 0));
    auto f = process_facts(pidfd, other);
    _exit(f.ok() && f->uid == 65534 && !f->exe_known ? 0 : 3);
  }
  int status = 0;
  waitpid(monitor, &status, 0);
  close(ready[1]);
  close(ready[0]);
  waitpid(other, nullptr, 0);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST(PeerIdentity, AProcessThatExitedGivesNoFacts) {
  const pid_t child = fork();
  if (child == 0) _exit(0);
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, child, 0));
  ASSERT_GE(pidfd, 0);
  siginfo_t info{};
  waitid(P_PIDFD, static_cast<id_t>(pidfd), &info, WEXITED);
  EXPECT_FALSE(process_facts(pidfd, child).ok());
  close(pidfd);
}

}  // namespace
}  // namespace contego::monitor
