// The audit log under faults (issue 11): a target that is not a regular
// file, a second writer, a full file system, truncation, deletion and
// replacement while running, size rotation and reopen: no SIGBUS, no line
// lost silently (a record that is not written says so), and the chain
// verifies across the files.
#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <string>
#include <sys/mount.h>
#include <sys/stat.h>
#include <thread>
#include <vector>

#include "base/test_temp.h"
#include "monitor/audit_log.h"
#include "monitor/test_audit_record.h"

namespace contego::monitor {
namespace {

core::AuditRecord record(uint32_t job) {
  static const uint8_t bytes[] = {0x01, 0x46, 0x64, 0x00, 0x00};
  return testing::decision_record(job, core::Decision::kAllow, 0x08, bytes);
}

AuditCheck verify_file(const std::string& path, const std::string& from = {}) {
  std::ifstream in(path);
  return verify_audit(in, from);
}

// Verifies files oldest first as one chain; returns the lines in all.
uint64_t verify_chain(const std::vector<std::string>& files) {
  std::string last;
  uint64_t lines = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    const AuditCheck c = verify_file(files[i], i == 0 ? std::string() : last);
    EXPECT_TRUE(c.ok) << files[i] << ": " << c.error;
    if (!c.ok) return 0;
    last = c.summary.last_hash;
    lines += c.summary.lines;
  }
  return lines;
}

std::string first_line(const std::string& path) {
  std::ifstream in(path);
  std::string l;
  std::getline(in, l);
  return l;
}

class AuditFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(test_support::make_temp_dir("contego-audit-faults", &dir));
    path = dir + "/audit.jsonl";
  }
  void TearDown() override {
    if (mounted) umount2(dir.c_str(), MNT_DETACH);
    (void)!system(("rm -rf " + dir).c_str());
  }
  std::string dir, path;
  bool mounted = false;
};

TEST_F(AuditFaults, TargetsThatAreNotRegularFilesAreRefused) {
  AuditLog full;
  Status s = full.open("/dev/full");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("character device"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("--audit-unsafe"), std::string::npos) << s.error();
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  AuditLog f;
  s = f.open(fifo);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("FIFO"), std::string::npos) << s.error();
  AuditLog d;
  EXPECT_FALSE(d.open(dir).ok());
  AuditLog err;
  EXPECT_TRUE(err.open("-").ok());  // standard error stays allowed
}

// --audit-unsafe on /dev/full: opened, but every record reports failure
// (the monitor then refuses every action): never a silent loss.
TEST_F(AuditFaults, UnsafeDevFullFailsEveryRecord) {
  AuditLog log;
  AuditOptions o;
  o.allow_unsafe = true;
  ASSERT_TRUE(log.open("/dev/full", o).ok());
  EXPECT_FALSE(log.event("start", "x"));
  EXPECT_FALSE(log.decision(record(1), "t"));
  EXPECT_EQ(log.failures(), 2u);
}

// --audit-unsafe on a FIFO: opened write-only, so the monitor is never a
// reader of its own log. No reader at open: refused, saying so. A reader that
// leaves: every later record fails (EPIPE, no SIGPIPE that would end the
// monitor), so what it would record does not act.
TEST_F(AuditFaults, UnsafeFifoNoticesItsReaderLeaving) {
  const std::string fifo = dir + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  AuditOptions o;
  o.allow_unsafe = true;
  AuditLog lonely;
  const Status s = lonely.open(fifo, o);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("no process reads it"), std::string::npos) << s.error();
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  AuditLog log;
  ASSERT_TRUE(log.open(fifo, o).ok());
  EXPECT_TRUE(log.event("start", "x"));
  char buf[4096];
  EXPECT_GT(::read(reader, buf, sizeof buf), 0);
  ::close(reader);
  EXPECT_FALSE(log.event("after", "the reader left"));
  EXPECT_FALSE(log.decision(record(1), "t"));
  EXPECT_EQ(log.failures(), 2u);
  sigset_t pending;
  sigpending(&pending);
  EXPECT_EQ(sigismember(&pending, SIGPIPE), 0) << "a SIGPIPE was left pending";
}

TEST_F(AuditFaults, ASecondWriterIsRefusedAndNamesTheHolder) {
  AuditLog first;
  ASSERT_TRUE(first.open(path).ok());
  ASSERT_TRUE(first.event("start", "first"));
  AuditLog second;
  const Status s = second.open(path);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("in use by another writer"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("pid " + std::to_string(getpid())), std::string::npos) << s.error();
  ASSERT_TRUE(first.event("still", "first"));
}

// copytruncate: the file is cut to zero under the mapping. Immediately (the
// copy's SIGBUS guard) and after the periodic check: no crash, the record is
// written, and the cut file starts with a `continues` record whose chain
// continues from the copy.
TEST_F(AuditFaults, TruncationUnderTheWriterContinuesTheChain) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  for (uint32_t i = 0; i < 50; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  // Copy what is there (logrotate's copy), then cut.
  ASSERT_EQ(system(("tr -d '\\000' < " + path + " > " + path + ".1").c_str()), 0);
  ASSERT_EQ(truncate(path.c_str(), 0), 0);
  EXPECT_TRUE(log.decision(record(50), "t"));  // SIGBUS guard path
  for (uint32_t i = 51; i < 60; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  ASSERT_EQ(system(("tr -d '\\000' < " + path + " >> " + path + ".1").c_str()), 0);
  ASSERT_EQ(truncate(path.c_str(), 0), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  EXPECT_TRUE(log.decision(record(60), "t"));  // periodic check path
  EXPECT_EQ(log.failures(), 0u);
  const auto j = nlohmann::json::parse(first_line(path));
  EXPECT_EQ(j["kind"], "continues");
  EXPECT_NE(j["detail"].get<std::string>().find("cut"), std::string::npos);
  // path.1 holds both copies; the live file continues from its end.
  EXPECT_EQ(verify_chain({path + ".1", path}), 50u + 1 + 10 + 1 + 1);
}

TEST_F(AuditFaults, DeletionOpensANewFileThatContinuesTheChain) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  for (uint32_t i = 0; i < 10; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  ASSERT_EQ(system(("cp " + path + " " + dir + "/saved").c_str()), 0);
  ASSERT_EQ(unlink(path.c_str()), 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(150));
  ASSERT_TRUE(log.decision(record(10), "t"));
  struct stat st {};
  ASSERT_EQ(stat(path.c_str(), &st), 0) << "no new file at the path";
  const auto j = nlohmann::json::parse(first_line(path));
  EXPECT_EQ(j["kind"], "continues");
  EXPECT_NE(j["detail"].get<std::string>().find("deleted"), std::string::npos);
  EXPECT_NE(j["follows"].get<std::string>().find("(deleted)"), std::string::npos);
  EXPECT_EQ(verify_chain({dir + "/saved", path}), 10u + 2);
}

TEST_F(AuditFaults, SizeRotationKeepsNFilesAndOneChain) {
  AuditLog log;
  AuditOptions o;
  o.max_bytes = 8192;
  o.keep = 3;
  ASSERT_TRUE(log.open(path, o).ok());
  for (uint32_t i = 0; i < 60; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  // ~300-byte lines: about 27 per file, two rotations so far.
  EXPECT_EQ(log.rotations(), 2u);
  struct stat st {};
  ASSERT_EQ(stat((path + ".2").c_str(), &st), 0);
  EXPECT_LE(static_cast<uint64_t>(st.st_size), o.max_bytes);
  const uint64_t lines = verify_chain({path + ".2", path + ".1", path});
  EXPECT_EQ(lines, 60u + 2);  // each new file starts with its continues record
  EXPECT_TRUE(verify_file(path + ".2").summary.starts_at_genesis);
  const auto j = nlohmann::json::parse(first_line(path));
  EXPECT_EQ(j["kind"], "continues");
  EXPECT_EQ(j["follows"], path + ".1");
  EXPECT_EQ(j["prev"], j["continues"]);
  for (uint32_t i = 60; i < 200; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  EXPECT_NE(stat((path + ".3").c_str(), &st), -1);
  EXPECT_EQ(stat((path + ".4").c_str(), &st), -1) << "keep = 3";
  verify_chain({path + ".3", path + ".2", path + ".1", path});
  // A file out of order breaks the chain, and says so.
  const AuditCheck c = verify_file(path + ".2", verify_file(path + ".1").summary.last_hash);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.error.find("does not continue"), std::string::npos) << c.error;
}

// logrotate's create mode: the file is renamed, then SIGHUP (reopen()).
TEST_F(AuditFaults, ReopenAfterAMoveContinuesInANewFile) {
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  for (uint32_t i = 0; i < 5; ++i) ASSERT_TRUE(log.decision(record(i), "t"));
  auto same = log.reopen();
  ASSERT_TRUE(same.ok());
  EXPECT_NE(same->find("kept"), std::string::npos) << *same;
  ASSERT_EQ(rename(path.c_str(), (path + ".old").c_str()), 0);
  auto r = log.reopen();
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_TRUE(log.decision(record(5), "t"));
  const auto j = nlohmann::json::parse(first_line(path));
  EXPECT_EQ(j["kind"], "continues");
  EXPECT_EQ(j["follows"], path + ".old");
  EXPECT_EQ(verify_chain({path + ".old", path}), 5u + 2);
}

// A file system of 256 KiB: records fill it; then every record reports
// failure (no SIGBUS, nothing written half), the file verifies, and once
// space is freed records are written again.
TEST_F(AuditFaults, AFullFileSystemFailsRecordsWithoutSigbus) {
  if (mount("none", dir.c_str(), "tmpfs", 0, "size=256k") != 0) {
    GTEST_SKIP() << "cannot mount a tmpfs here (" << strerror(errno) << "): needs root";
  }
  mounted = true;
  {
    std::ofstream filler(dir + "/filler");
    filler << std::string(96 * 1024, 'x');
  }
  AuditLog log;
  ASSERT_TRUE(log.open(path).ok());
  uint64_t written = 0;
  uint32_t i = 0;
  for (; i < 5000; ++i) {
    if (!log.decision(record(i), "t")) break;
    ++written;
  }
  ASSERT_LT(i, 5000u) << "the file system never filled";
  for (int k = 0; k < 20; ++k) EXPECT_FALSE(log.decision(record(i), "t"));
  EXPECT_EQ(log.failures(), 21u);
  const AuditCheck c = verify_file(path);
  ASSERT_TRUE(c.ok) << c.error;
  EXPECT_EQ(c.summary.lines, written);  // what was reported written, and only that
  ASSERT_EQ(unlink((dir + "/filler").c_str()), 0);
  EXPECT_TRUE(log.decision(record(i), "t"));
  const AuditCheck after = verify_file(path);
  EXPECT_EQ(after.summary.lines, written + 2);  // the audit-gap record, then the decision
  EXPECT_EQ(after.summary.events.at("audit-gap"), 1u);
}

TEST_F(AuditFaults, AFullFileSystemIsRefusedAtOpen) {
  if (mount("none", dir.c_str(), "tmpfs", 0, "size=64k") != 0) {
    GTEST_SKIP() << "cannot mount a tmpfs here (" << strerror(errno) << "): needs root";
  }
  mounted = true;
  { std::ofstream(dir + "/filler") << std::string(64 * 1024, 'x'); }
  AuditLog log;
  const Status s = log.open(path);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("no room"), std::string::npos) << s.error();
}

}  // namespace
}  // namespace contego::monitor

namespace contego::monitor {
namespace {

// With a size limit, SIGHUP rotates now; after logrotate moved the file
// away it reopens the path instead (nothing left to rename).
TEST_F(AuditFaults, ReopenWithASizeLimitRotatesOrFollowsAMove) {
  AuditLog log;
  AuditOptions o;
  o.max_bytes = 1 << 20;
  ASSERT_TRUE(log.open(path, o).ok());
  ASSERT_TRUE(log.decision(record(0), "t"));
  auto r = log.reopen();
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("rotated"), std::string::npos) << *r;
  ASSERT_TRUE(log.decision(record(1), "t"));
  ASSERT_EQ(rename(path.c_str(), (path + ".moved").c_str()), 0);
  r = log.reopen();
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("reopened"), std::string::npos) << *r;
  ASSERT_TRUE(log.decision(record(2), "t"));
  EXPECT_EQ(verify_chain({path + ".1", path + ".moved", path}), 1u + 2 + 2);
}

// A burst of SIGHUPs rotates once: a file that recorded nothing since it
// began (its continues record and the SIGHUP's own signal lines aside) is
// kept, so empty files cannot push the kept ones out.
TEST_F(AuditFaults, SighupBurstRotatesOnlyAFileThatRecordedSomething) {
  AuditLog log;
  AuditOptions o;
  o.max_bytes = 1 << 20;
  o.keep = 2;
  ASSERT_TRUE(log.open(path, o).ok());
  ASSERT_TRUE(log.decision(record(0), "t"));
  auto r = log.reopen();
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("rotated"), std::string::npos) << *r;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(log.event("signal", "SIGHUP"));
    r = log.reopen();
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_NE(r->find("kept, not rotated"), std::string::npos) << *r;
  }
  EXPECT_EQ(log.rotations(), 1u);
  ASSERT_TRUE(log.decision(record(1), "t"));
  r = log.reopen();
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->find("rotated"), std::string::npos) << *r;
  // The first file's decision is still kept (LOG.2), not pushed out.
  EXPECT_EQ(verify_chain({path + ".2", path + ".1", path}), 1u + 7 + 1);
}

}  // namespace
}  // namespace contego::monitor
