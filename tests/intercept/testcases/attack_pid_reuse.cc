// A process opens the bus and dies; a new process is then created under the
// dead one's number (clone3 with set_tid, or, where clone3 is refused as
// under contego's seccomp filter, fork after writing the number before it
// to /proc/sys/kernel/ns_last_pid; both need CAP_SYS_ADMIN) and uses the
// descriptor number the dead one held, without opening anything.
// The new process holds no such descriptor, so the call must fail with
// EBADF and nothing may reach the bus. Prints "<step> <result> <errno>";
// "reuse-skipped" when the number cannot be chosen here.
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <linux/i2c-dev.h>
#include <linux/sched.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>

static void report(const char* what, long r) {
  std::printf("%s %ld %d\n", what, r, r < 0 ? errno : 0);
  std::fflush(stdout);
}

int main() {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return 2;
  const pid_t first = fork();
  if (first == 0) {
    const int fd = open("/dev/i2c-1", O_RDWR);
    (void)!write(pipe_fds[1], &fd, sizeof fd);
    _exit(fd >= 0 ? 0 : 1);  // dies holding the descriptor
  }
  int bus_fd = -1;
  if (read(pipe_fds[0], &bus_fd, sizeof bus_fd) != sizeof bus_fd) return 2;
  int status = 0;
  waitpid(first, &status, 0);  // reaped: the number is free again
  report("first-open", bus_fd);
  if (bus_fd < 0) return 2;

  // The new process: same number as the one that held bus_fd; it never
  // opened it.
  auto use_dead_ones_descriptor = [bus_fd] {
    unsigned char led[2] = {0x07, 0x5A};
    long r = ioctl(bus_fd, I2C_SLAVE, 0x40);
    const int slave_errno = r < 0 ? errno : 0;
    r = write(bus_fd, led, 2);
    std::printf("reuse-slave %d\nreuse-write %ld %d\n", slave_errno, r, r < 0 ? errno : 0);
    std::fflush(stdout);
    _exit(0);
  };
  pid_t wanted = first;
  clone_args args{};
  args.exit_signal = SIGCHLD;
  args.set_tid = reinterpret_cast<uintptr_t>(&wanted);
  args.set_tid_size = 1;
  long second = syscall(SYS_clone3, &args, sizeof args);
  if (second == 0) use_dead_ones_descriptor();
  if (second > 0) waitpid(static_cast<pid_t>(second), &status, 0);
  // ns_last_pid: the next fork gets the number after the one written,
  // unless another process forks in between (then try again).
  for (int attempt = 0; second < 0 && attempt < 20; ++attempt) {
    FILE* last = std::fopen("/proc/sys/kernel/ns_last_pid", "w");
    if (last == nullptr) break;
    const bool set = std::fprintf(last, "%d", first - 1) > 0;
    if (std::fclose(last) != 0 || !set) break;
    const pid_t child = fork();
    if (child == 0) {
      if (getpid() == first) use_dead_ones_descriptor();
      _exit(3);  // another number: not this test's case
    }
    if (child < 0) break;
    waitpid(child, &status, 0);
    if (child == first) second = child;
  }
  if (second < 0) {
    report("reuse-skipped", second);
    return 0;
  }
  report("reuse-same-number", second == first ? 0 : -1);
  return 0;
}
