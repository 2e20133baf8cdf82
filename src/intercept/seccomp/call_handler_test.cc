// The call handler's logic against a fake notification channel and a fake
// endpoint, with no seccomp filter: the "caller" of every call is this very
// process (its own thread id as the notification's pid, arguments pointing
// into its own memory), so /proc, pidfds, kcmp and process_vm_readv see a
// real process, and a descriptor the fake channel "installs into the caller"
// lands in this process's table. Calls that end a process name a sleeping
// child instead.
#include "intercept/seccomp/call_handler.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <functional>
#include <gtest/gtest.h>
#include <linux/audit.h>
#include <linux/close_range.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <string>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <vector>

#include "intercept/seccomp/audit_arch.h"

namespace contego::intercept::seccomp {
namespace {

constexpr FdRange kRange{512, 64};
constexpr uint8_t kBus = 1;  // the one bus the fake trusted side has

struct Answer {
  enum class Kind { kNone, kReply, kContinue, kAddFd } kind = Kind::kNone;
  uint64_t id = 0;
  int64_t value = 0;  // kReply: the value; kAddFd: the slot
  int err = 0;
  bool cloexec = false;  // kAddFd
};

class FakeChannel final : public NotificationChannel {
 public:
  std::vector<Answer> answers;
  bool pending = true;  // what valid() says

  int receive(seccomp_notif&) override { return ENOENT; }  // calls are handed to handle()
  bool valid(uint64_t) override { return pending; }
  void reply(uint64_t id, int64_t value, int err) override {
    answers.push_back({Answer::Kind::kReply, id, value, err, false});
  }
  void continue_call(uint64_t id) override {
    answers.push_back({Answer::Kind::kContinue, id, 0, 0, false});
  }
  // As the kernel would into the caller, which is this process.
  int add_fd(uint64_t id, int own_fd, int slot, bool cloexec) override {
    if (dup3(own_fd, slot, cloexec ? O_CLOEXEC : 0) != slot) return -1;
    answers.push_back({Answer::Kind::kAddFd, id, slot, 0, cloexec});
    return slot;
  }
};

class FakeEndpoint final : public gate::Endpoint {
 public:
  std::vector<gate::Transfer> transfers;
  gate::TransferReply next_reply;
  std::function<void()> during_transfer;
  int job_boundaries = 0;

  gate::TransferReply transfer(uint16_t, const gate::Transfer& t) override {
    transfers.push_back(t);
    if (during_transfer) during_transfer();
    return next_reply;
  }
  void job_boundary(uint16_t) override { ++job_boundaries; }
  void task_exited(uint16_t) override {}
  bool has_bus(uint8_t bus) override { return bus == kBus; }
  uint64_t funcs(uint8_t) override { return I2C_FUNC_I2C; }
};

// A child that only waits to be killed; reaped (and killed if need be) at the end.
class Sleeper {
 public:
  Sleeper() : pid_(fork()) {
    if (pid_ == 0) {
      for (;;) pause();
    }
  }
  ~Sleeper() {
    if (!reaped_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  Sleeper(const Sleeper&) = delete;
  Sleeper& operator=(const Sleeper&) = delete;
  pid_t pid() const { return pid_; }
  // The signal that ended it, waiting up to `ms` milliseconds; 0 if it still runs.
  int ended_by(int ms = 1000) {
    for (int i = 0; i < ms && !reaped_; ++i) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        reaped_ = true;
        signal_ = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
      } else {
        usleep(1000);
      }
    }
    return signal_;
  }

 private:
  pid_t pid_;
  bool reaped_ = false;
  int signal_ = 0;
};

uint64_t address(const void* p) { return reinterpret_cast<uint64_t>(p); }
// A system call argument as the notification carries it.
uint64_t word(long v) { return static_cast<uint64_t>(v); }

bool kcmp_works() {
  constexpr int kKcmpFile = 0;
  const int fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const bool works = syscall(SYS_kcmp, getpid(), getpid(), kKcmpFile, fd, fd) == 0;
  close(fd);
  return works;
}

class CallHandlerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    rlimit lim{};
    getrlimit(RLIMIT_NOFILE, &lim);
    if (lim.rlim_cur < static_cast<rlim_t>(kRange.first + kRange.count)) {
      GTEST_SKIP() << "RLIMIT_NOFILE below the test's reserved range";
    }
    clear_range();
  }
  void TearDown() override { clear_range(); }
  static void clear_range() {
    syscall(SYS_close_range, kRange.first, kRange.first + kRange.count - 1, 0);
  }

  seccomp_notif call(long nr, std::array<uint64_t, 6> args, pid_t pid = gettid()) {
    seccomp_notif n{};
    n.id = ++last_id_;
    n.pid = static_cast<uint32_t>(pid);
    n.data.nr = static_cast<int>(nr);
    n.data.arch = kAuditArch;
    for (size_t i = 0; i < args.size(); ++i) n.data.args[i] = args[i];
    return n;
  }
  // Hands `n` to the handler: its one answer, or kNone.
  Answer handle(const seccomp_notif& n) {
    const size_t before = channel_.answers.size();
    handler_.handle(n);
    EXPECT_LE(channel_.answers.size(), before + 1) << "more than one answer";
    if (channel_.answers.size() == before) return {};
    EXPECT_EQ(channel_.answers.back().id, n.id);
    return channel_.answers.back();
  }
  Answer openat_call(const char* path, int flags, pid_t pid = gettid()) {
    return handle(call(__NR_openat, {word(AT_FDCWD), address(path), word(flags)}, pid));
  }
  // Opens the bus: the slot of its stand-in.
  int open_bus(int flags = O_RDWR) {
    const Answer a = openat_call("/dev/i2c-1", flags);
    EXPECT_EQ(a.kind, Answer::Kind::kAddFd);
    return a.kind == Answer::Kind::kAddFd ? static_cast<int>(a.value) : -1;
  }
  Answer write_bytes(int fd, const std::vector<uint8_t>& bytes) {
    return handle(call(__NR_write, {word(fd), address(bytes.data()), bytes.size()}));
  }
  Answer ioctl_call(int fd, unsigned long request, uint64_t arg) {
    return handle(call(__NR_ioctl, {word(fd), request, arg}));
  }
  Answer dup3_call(int oldfd, int newfd, int flags) {
    return handle(call(__NR_dup3, {word(oldfd), word(newfd), word(flags)}));
  }
  Answer fcntl_call(int fd, int cmd, uint64_t arg) {
    return handle(call(__NR_fcntl, {word(fd), word(cmd), arg}));
  }
  static void expect_reply(const Answer& a, int64_t value, int err) {
    EXPECT_EQ(a.kind, Answer::Kind::kReply);
    EXPECT_EQ(a.value, value);
    EXPECT_EQ(a.err, err);
  }

  Options options_;
  RunResult result_;
  FakeChannel channel_;
  FakeEndpoint endpoint_;
  CallHandler handler_{channel_, kRange, options_, endpoint_, result_};
  uint64_t last_id_ = 0;
};

using Kind = Answer::Kind;

TEST_F(CallHandlerTest, BusPathGetsAStandInAtTheFirstFreeReservedSlot) {
  const Answer first = openat_call("/dev/i2c-1", O_RDWR | O_CLOEXEC);
  ASSERT_EQ(first.kind, Kind::kAddFd);
  EXPECT_EQ(first.value, kRange.first);
  EXPECT_TRUE(first.cloexec);
  struct stat st {};
  ASSERT_EQ(fstat(kRange.first, &st), 0);  // what the caller now holds: /dev/null
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  EXPECT_EQ(st.st_rdev, makedev(1, 3));
  EXPECT_EQ(fcntl(kRange.first, F_GETFD), FD_CLOEXEC);

  const Answer second = openat_call("/dev/i2c/1", O_RDWR);
  ASSERT_EQ(second.kind, Kind::kAddFd);
  EXPECT_EQ(second.value, kRange.first + 1);
  EXPECT_FALSE(second.cloexec);
  // An ordinary descriptor that landed in the range (a full table) is kept.
  ASSERT_EQ(dup2(STDERR_FILENO, kRange.first + 2), kRange.first + 2);
  const Answer third = openat_call("/dev/i2c-1", O_RDWR);
  ASSERT_EQ(third.kind, Kind::kAddFd);
  EXPECT_EQ(third.value, kRange.first + 3);
  EXPECT_TRUE(endpoint_.transfers.empty());
}

TEST_F(CallHandlerTest, OtherPathsAreLeftToTheKernel) {
  EXPECT_EQ(openat_call("/dev/null", O_RDWR).kind, Kind::kContinue);
  EXPECT_EQ(fcntl(kRange.first, F_GETFD), -1);  // nothing installed
}

TEST_F(CallHandlerTest, BusTheTrustedSideLacksIsENOENT) {
  expect_reply(openat_call("/dev/i2c-7", O_RDWR), 0, ENOENT);
}

TEST_F(CallHandlerTest, UnreadablePathIsEFAULT) {
  expect_reply(handle(call(__NR_openat, {word(AT_FDCWD), 8, O_RDWR})), 0, EFAULT);
}

TEST_F(CallHandlerTest, OpenWithdrawnAfterItsPathWasReadIsNotAnswered) {
  EXPECT_EQ(openat_call("/dev/null", O_RDWR).kind, Kind::kContinue);  // the process is known
  channel_.pending = false;
  EXPECT_EQ(openat_call("/dev/i2c-1", O_RDWR).kind, Kind::kNone);
  EXPECT_EQ(fcntl(kRange.first, F_GETFD), -1);
}

TEST_F(CallHandlerTest, FirstCallOfAProcessGoneMeanwhileIsEIO) {
  channel_.pending = false;
  expect_reply(openat_call("/dev/i2c-1", O_RDWR), 0, EIO);
  EXPECT_EQ(fcntl(kRange.first, F_GETFD), -1);
}

TEST_F(CallHandlerTest, IoctlsAndWritesOnTheStandInAreEmulated) {
  const int fd = open_bus();
  uint64_t funcs = 0;
  expect_reply(ioctl_call(fd, I2C_FUNCS, address(&funcs)), 0, 0);
  EXPECT_EQ(funcs, I2C_FUNC_I2C);
  expect_reply(ioctl_call(fd, I2C_SLAVE, 0x48), 0, 0);
  expect_reply(ioctl_call(fd, I2C_SLAVE, 0x80), 0, EINVAL);  // beyond 7 bits
  EXPECT_TRUE(endpoint_.transfers.empty());

  expect_reply(write_bytes(fd, {0x01, 0x80}), 2, 0);
  ASSERT_EQ(endpoint_.transfers.size(), 1u);
  const gate::Transfer& t = endpoint_.transfers[0];
  EXPECT_EQ(t.bus, kBus);
  ASSERT_EQ(t.messages.size(), 1u);
  EXPECT_EQ(t.messages[0].addr, 0x48);
  EXPECT_EQ(t.messages[0].data, (std::vector<uint8_t>{0x01, 0x80}));
  EXPECT_EQ(result_.emulated, 1u);

  endpoint_.next_reply.err = EREMOTEIO;  // refused or failed on the trusted side
  expect_reply(write_bytes(fd, {0x02}), 0, EREMOTEIO);
  EXPECT_EQ(ioctl_call(fd, 0x5401 /* TCGETS */, 0).err, ENOTTY);
}

TEST_F(CallHandlerTest, RdwrReadsAreCopiedBackIntoTheCaller) {
  const int fd = open_bus();
  uint8_t reg = 0x05;
  uint8_t in[2] = {0, 0};
  i2c_msg msgs[2] = {{0x48, 0, 1, &reg}, {0x48, I2C_M_RD, 2, in}};
  i2c_rdwr_ioctl_data data{msgs, 2};
  endpoint_.next_reply.reads = {{0xAB, 0xCD}};
  expect_reply(ioctl_call(fd, I2C_RDWR, address(&data)), 2, 0);
  EXPECT_EQ(in[0], 0xAB);
  EXPECT_EQ(in[1], 0xCD);
  ASSERT_EQ(endpoint_.transfers.size(), 1u);
  ASSERT_EQ(endpoint_.transfers[0].messages.size(), 2u);
  EXPECT_EQ(endpoint_.transfers[0].messages[0].data, std::vector<uint8_t>{0x05});
  EXPECT_TRUE(endpoint_.transfers[0].messages[1].is_read());
  EXPECT_EQ(endpoint_.transfers[0].messages[1].len, 2);
}

TEST_F(CallHandlerTest, CallWithdrawnDuringItsTransferGetsNothingWritten) {
  const int fd = open_bus();
  uint8_t in[2] = {0, 0};
  i2c_msg msg{0x48, I2C_M_RD, 2, in};
  i2c_rdwr_ioctl_data data{&msg, 1};
  endpoint_.next_reply.reads = {{0xAB, 0xCD}};
  endpoint_.during_transfer = [&] { channel_.pending = false; };
  const Answer a = ioctl_call(fd, I2C_RDWR, address(&data));
  EXPECT_EQ(endpoint_.transfers.size(), 1u);
  EXPECT_EQ(in[0], 0);  // the memory may be another call's by now
  EXPECT_EQ(in[1], 0);
  EXPECT_FALSE(a.kind == Kind::kReply && a.err == 0);
}

TEST_F(CallHandlerTest, StaleBusCallIsNeitherPerformedNorAnswered) {
  const int fd = open_bus();
  expect_reply(ioctl_call(fd, I2C_SLAVE, 0x48), 0, 0);
  channel_.pending = false;
  EXPECT_EQ(write_bytes(fd, {0x01, 0x80}).kind, Kind::kNone);
  EXPECT_TRUE(endpoint_.transfers.empty());
  EXPECT_EQ(result_.emulated, 0u);
}

TEST_F(CallHandlerTest, PositionalAndVectorCallsOnABusAreRefused) {
  const int fd = open_bus();
  uint8_t buf[2] = {};
  const uint64_t f = word(fd);
  expect_reply(handle(call(__NR_pread64, {f, address(buf), 2, 0})), 0, ESPIPE);
  expect_reply(handle(call(__NR_pwrite64, {f, address(buf), 2, 0})), 0, ESPIPE);
  expect_reply(handle(call(__NR_preadv2, {f, address(buf), 1, 0, 0, 0})), 0, ESPIPE);
  expect_reply(handle(call(__NR_readv, {f, address(buf), 1})), 0, EINVAL);
  expect_reply(handle(call(__NR_writev, {f, address(buf), 1})), 0, EINVAL);
  EXPECT_TRUE(endpoint_.transfers.empty());
}

TEST_F(CallHandlerTest, CopiesOfABusDescriptorStayInTheRange) {
  const int fd = open_bus();
  const Answer dupfd = fcntl_call(fd, F_DUPFD_CLOEXEC, 0);
  ASSERT_EQ(dupfd.kind, Kind::kAddFd);
  EXPECT_EQ(dupfd.value, fd + 1);
  EXPECT_TRUE(dupfd.cloexec);
  const Answer above = fcntl_call(fd, F_DUPFD, kRange.first + 10);
  ASSERT_EQ(above.kind, Kind::kAddFd);
  EXPECT_EQ(above.value, kRange.first + 10);
  EXPECT_FALSE(above.cloexec);
  const Answer plain = handle(call(__NR_dup, {word(fd)}));
  ASSERT_EQ(plain.kind, Kind::kAddFd);
  EXPECT_EQ(plain.value, fd + 2);

  const int target = kRange.first + 20;
  const Answer three = dup3_call(fd, target, O_CLOEXEC);
  ASSERT_EQ(three.kind, Kind::kAddFd);
  EXPECT_EQ(three.value, target);
  EXPECT_TRUE(three.cloexec);
  expect_reply(dup3_call(fd, STDERR_FILENO + 100, 0), 0, EPERM);  // out of the range
  expect_reply(dup3_call(fd, fd, 0), 0, EINVAL);
  // The copy is the same bus (same address: one open file).
  expect_reply(ioctl_call(fd, I2C_SLAVE, 0x21), 0, 0);
  expect_reply(write_bytes(target, {0x07}), 1, 0);
  ASSERT_EQ(endpoint_.transfers.size(), 1u);
  EXPECT_EQ(endpoint_.transfers[0].messages[0].addr, 0x21);
}

TEST_F(CallHandlerTest, OrdinaryDescriptorsNeverEnterTheRange) {
  expect_reply(fcntl_call(STDERR_FILENO, F_DUPFD, kRange.first), 0, EINVAL);
  expect_reply(fcntl_call(STDERR_FILENO, F_DUPFD_CLOEXEC, kRange.first), 0, EINVAL);
  expect_reply(dup3_call(STDERR_FILENO, kRange.first + 5, 0), 0, EBADF);
  // A number in the range that is no bus: the kernel answers (EBADF there).
  EXPECT_EQ(fcntl_call(kRange.first + 5, F_DUPFD, 0).kind, Kind::kContinue);
  EXPECT_EQ(fcntl(kRange.first + 5, F_GETFD), -1);
}

TEST_F(CallHandlerTest, ClosedBusDescriptorIsForgotten) {
  const int fd = open_bus();
  EXPECT_EQ(handle(call(__NR_close, {word(fd)})).kind, Kind::kContinue);
  EXPECT_EQ(write_bytes(fd, {0x01}).kind, Kind::kContinue);  // the kernel's /dev/null now
  const int a = open_bus();
  const int b = open_bus();
  EXPECT_EQ(handle(call(__NR_close_range, {word(a), word(b), 0})).kind, Kind::kContinue);
  EXPECT_EQ(write_bytes(a, {0x01}).kind, Kind::kContinue);
  EXPECT_EQ(write_bytes(b, {0x01}).kind, Kind::kContinue);
  EXPECT_TRUE(endpoint_.transfers.empty());
}

TEST_F(CallHandlerTest, ExecForgetsCloseOnExecBusDescriptorsAndChecksTheNewImage) {
  std::vector<pid_t> asked;
  options_.on_exec = [&](pid_t pid) -> Status {
    asked.push_back(pid);
    return {};
  };
  const int closed_at_exec = open_bus(O_RDWR | O_CLOEXEC);
  const int kept = open_bus();
  const int marked = open_bus();
  const int unmarked = open_bus();
  ASSERT_EQ(fcntl_call(unmarked, F_SETFD, FD_CLOEXEC).kind, Kind::kContinue);
  ASSERT_EQ(fcntl_call(unmarked, F_SETFD, 0).kind, Kind::kContinue);
  ASSERT_EQ(handle(call(__NR_close_range, {word(marked), word(marked), CLOSE_RANGE_CLOEXEC})).kind,
            Kind::kContinue);
  EXPECT_EQ(handle(call(__NR_execve, {0, 0, 0})).kind, Kind::kContinue);
  EXPECT_TRUE(asked.empty());  // not before the new image's first call
  EXPECT_EQ(write_bytes(closed_at_exec, {0x01}).kind, Kind::kContinue);
  EXPECT_EQ(asked, std::vector<pid_t>{gettid()});
  EXPECT_EQ(write_bytes(marked, {0x01}).kind, Kind::kContinue);
  expect_reply(write_bytes(kept, {0x01}), 1, 0);
  expect_reply(write_bytes(unmarked, {0x01}), 1, 0);
  EXPECT_EQ(endpoint_.transfers.size(), 2u);
  EXPECT_EQ(asked.size(), 1u);
}

TEST_F(CallHandlerTest, DescriptorReplacedBehindTheHandlersBackIsNoLongerTheBus) {
  if (!kcmp_works()) GTEST_SKIP() << "no kcmp: descriptor tables are trusted";
  const int fd = open_bus();
  const int zero = ::open("/dev/zero", O_RDONLY | O_CLOEXEC);
  ASSERT_GE(zero, 0);
  ASSERT_EQ(dup2(zero, fd), fd);  // as a CLONE_FILES sibling could
  close(zero);
  expect_reply(write_bytes(fd, {0x01}), 0, EBADF);
  EXPECT_EQ(write_bytes(fd, {0x01}).kind, Kind::kContinue);  // forgotten
  EXPECT_TRUE(endpoint_.transfers.empty());
}

TEST_F(CallHandlerTest, SleepsAreJobBoundaries) {
  EXPECT_EQ(handle(call(__NR_nanosleep, {0, 0})).kind, Kind::kContinue);
  EXPECT_EQ(handle(call(__NR_clock_nanosleep, {0, 0, 0, 0})).kind, Kind::kContinue);
  EXPECT_EQ(endpoint_.job_boundaries, 2);
}

TEST_F(CallHandlerTest, CallOfAnotherArchitectureIsENOSYS) {
  seccomp_notif n = call(__NR_openat, {word(AT_FDCWD), address("/dev/i2c-1"), 0});
  n.data.arch = kAuditArch == AUDIT_ARCH_X86_64 ? AUDIT_ARCH_I386 : AUDIT_ARCH_ARM;
  expect_reply(handle(n), 0, ENOSYS);
  EXPECT_EQ(result_.notifications, 1u);
}

TEST_F(CallHandlerTest, CloseDownKillsTheKnownProcesses) {
  Sleeper child;
  EXPECT_EQ(handle(call(__NR_close, {3}, child.pid())).kind, Kind::kContinue);
  handler_.close_down();
  EXPECT_EQ(child.ended_by(), SIGKILL);
}

TEST_F(CallHandlerTest, AfterCloseDownEveryCallIsEIOAndItsCallerKilled) {
  Sleeper child;
  handler_.close_down();
  expect_reply(handle(call(__NR_nanosleep, {0, 0}, child.pid())), 0, EIO);
  EXPECT_EQ(endpoint_.job_boundaries, 0);
  EXPECT_EQ(child.ended_by(), SIGKILL);
}

TEST_F(CallHandlerTest, NewImageRefusedByOnExecEndsTheProgram) {
  options_.on_exec = [](pid_t) -> Status { return make_error("not the task's program"); };
  Sleeper child;
  EXPECT_EQ(handle(call(__NR_execve, {0, 0, 0}, child.pid())).kind, Kind::kContinue);
  EXPECT_EQ(child.ended_by(50), 0);
  expect_reply(handle(call(__NR_close, {3}, child.pid())), 0, EIO);
  EXPECT_EQ(result_.identity_refused, "not the task's program");
  EXPECT_EQ(child.ended_by(), SIGKILL);
}

}  // namespace
}  // namespace contego::intercept::seccomp
