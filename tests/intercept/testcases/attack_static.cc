// A statically linked program (no libc symbols to interpose) trying every
// way around the firewall. Each line printed is "<attack> <result>"; the
// test reads the device afterwards, which is what matters.
#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <sys/wait.h>

static void report(const char* what, long r) {
  std::printf("%s %ld %d\n", what, r, r < 0 ? errno : 0);
}

int main() {
  // Another name for the bus.
  int fd = open("/dev/../dev//i2c-1", O_RDWR);
  report("open-other-path", fd);
  if (fd < 0) return 2;
  report("slave-force", ioctl(fd, I2C_SLAVE_FORCE, 0x40));
  unsigned char prescale[2] = {0xFE, 0x03};
  report("write-prescale", write(fd, prescale, 2));
  // Raw syscall (no libc wrapper to interpose).
  report("raw-write-prescale", syscall(SYS_write, fd, prescale, 2));
  // The all-call address.
  report("slave-allcall", ioctl(fd, I2C_SLAVE, 0x70));
  unsigned char allled[2] = {0xFD, 0x10};
  report("write-allcall", write(fd, allled, 2));
  // A write smuggled inside a combined transfer.
  unsigned char reg = 0x00, val = 0;
  i2c_msg msgs[3] = {{0x40, 0, 1, &reg}, {0x40, I2C_M_RD, 1, &val}, {0x40, 0, 2, prescale}};
  i2c_rdwr_ioctl_data rdwr{msgs, 3};
  report("rdwr-smuggle", ioctl(fd, I2C_RDWR, &rdwr));
  // dup2 of the bus descriptor out of the reserved range, then write through it.
  report("dup2-out", dup2(fd, 10));
  report("write-via-10", write(10, prescale, 2));
  // dup inside the range keeps working and stays checked.
  int copy = dup(fd);
  report("dup", copy >= 0 ? 0 : -1);
  report("slave-copy", ioctl(copy, I2C_SLAVE, 0x40));
  report("write-prescale-copy", write(copy, prescale, 2));
  // fork: the child inherits the descriptor and the filter.
  pid_t pid = fork();
  if (pid == 0) {
    long r = write(fd, prescale, 2);
    _exit(r == 2 ? 1 : 0);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  report("fork-child-denied", WIFEXITED(status) && WEXITSTATUS(status) == 0 ? 0 : -1);
  // exec: the filter survives; the new image tries once more via i2cset.
  std::fflush(stdout);
  execl("/usr/sbin/i2cset", "i2cset", "-y", "1", "0x40", "0xfe", "0x03",
        static_cast<char*>(nullptr));
  return 3;
}
