// A hostile program under `contego run` (issue 11, parts 1 and 2). Modes:
//  hello SOCKET TASK        open its own connection to the monitor and say
//                           hello as TASK; exit 0 if refused, 1 if accepted
//  loop SOCKET TASK N       connect, hello, close N times; prints how many
//                           hellos were accepted; exit 0 if none
//  supervisor               ptrace(PTRACE_ATTACH), process_vm_writev and
//                           pidfd_getfd against its supervisor (the parent);
//                           exit 0 if every one failed
//  escape                   unshare(CLONE_NEWUSER), unshare(CLONE_NEWNS),
//                           chroot("/dev"), mknod of an i2c char node
//                           (major 89); exit 0 if every one failed
//  clone-files              open /dev/i2c-1, select 0x40, let a CLONE_FILES
//                           sibling close the descriptor, then write MODE1 =
//                           0x31 on it: exit 0 if that fails with EBADF, 1 if
//                           it acted
//  open HOW DIR             DIR holds the bus node `i2c-1`; open it by another
//                           name (HOW: proc-self, thread-self, openat2-in-root,
//                           symlink, dotdot), then select 0x40 and write
//                           MODE1 = 0x31 (sleep, every servo off). Exit 0 if
//                           the open was emulated and the write refused by the
//                           policy (EPERM), 1 if the write reported success
//                           (acted, or ignored by the policy: read the device
//                           back), 2 if the open
//                           failed (it went to the kernel), 3 otherwise
// Speaks the wire protocol by hand (an attacker needs no library).
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <linux/i2c-dev.h>
#include <linux/openat2.h>
#include <string>
#include <sys/ioctl.h>
#include <sys/ptrace.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <sys/wait.h>

namespace {

// 1: accepted, 0: refused, -1: no connection.
int hello(const char* path, const char* task) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  strncpy(addr.sun_path, path, sizeof addr.sun_path - 1);
  const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0 || connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    printf("connect: %s\n", strerror(errno));
    if (fd >= 0) close(fd);
    return -1;
  }
  const size_t n = strlen(task);
  uint8_t frame[12 + 2 + 64] = {0x43, 0x47, 1, 1, 1, 0, 0, 0};
  const uint32_t len = static_cast<uint32_t>(2 + n);
  frame[8] = static_cast<uint8_t>(len);
  frame[12] = static_cast<uint8_t>(n);
  memcpy(frame + 14, task, n);
  if (send(fd, frame, 12 + len, MSG_NOSIGNAL) != static_cast<ssize_t>(12 + len)) {
    close(fd);
    return 0;  // the monitor answered and closed before reading: refused
  }
  uint8_t answer[512];
  const ssize_t got = read(fd, answer, sizeof answer);
  close(fd);
  if (got < 12) return -1;
  if (answer[3] == 2) return 1;  // kHelloOk
  if (got > 18) printf("refused: %.*s\n", static_cast<int>(got - 18), answer + 18);
  return 0;
}

int supervisor() {
  const pid_t parent = getppid();
  int acted = 0;
  if (ptrace(PTRACE_ATTACH, parent, nullptr, nullptr) == 0) {
    printf("ptrace attached to the supervisor\n");
    ++acted;
  } else {
    printf("ptrace: %s\n", strerror(errno));
  }
  char byte = 0;
  iovec local{&byte, 1}, remote{reinterpret_cast<void*>(&byte), 1};
  if (process_vm_writev(parent, &local, 1, &remote, 1, 0) >= 0) {
    printf("process_vm_writev reached the supervisor\n");
    ++acted;
  } else {
    printf("process_vm_writev: %s\n", strerror(errno));
  }
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, parent, 0));
  for (int fd = 0; fd < 64 && pidfd >= 0; ++fd) {
    const int copy = static_cast<int>(syscall(SYS_pidfd_getfd, pidfd, fd, 0));
    if (copy >= 0) {
      printf("pidfd_getfd copied the supervisor's descriptor %d\n", fd);
      ++acted;
      break;
    }
    if (fd == 63) printf("pidfd_getfd: %s\n", strerror(errno));
  }
  return acted == 0 ? 0 : 1;
}

int escape() {
  int acted = 0;
  auto attempt = [&](const char* what, int rc) {
    printf("%s: %s\n", what, rc == 0 ? "succeeded" : strerror(errno));
    acted += rc == 0;
  };
  attempt("unshare(CLONE_NEWUSER)", unshare(CLONE_NEWUSER));
  attempt("unshare(CLONE_NEWNS)", unshare(CLONE_NEWNS));
  attempt("chroot(/dev)", chroot("/dev"));
  char node[] = "/tmp/contego-attack-i2c-XXXXXX";
  const int tmp = mkstemp(node);
  if (tmp >= 0) {
    close(tmp);
    unlink(node);
  }
  attempt("mknod(i2c 89:1)", mknod(node, S_IFCHR | 0600, makedev(89, 1)));
  unlink(node);
  return acted == 0 ? 0 : 1;
}

int open_other_name(const char* how, const char* dir) {
  int fd = -1;
  const std::string d = dir;
  if (strcmp(how, "proc-self") == 0) {
    if (chdir(dir) != 0) return 3;
    fd = open("/proc/self/cwd/i2c-1", O_RDWR);
  } else if (strcmp(how, "thread-self") == 0) {
    if (chdir(dir) != 0) return 3;
    fd = open("/proc/thread-self/cwd/i2c-1", O_RDWR);
  } else if (strcmp(how, "openat2-in-root") == 0) {
    const int dirfd = open(dir, O_PATH | O_DIRECTORY);
    open_how h{};
    h.flags = O_RDWR;
    h.resolve = RESOLVE_IN_ROOT;
    fd = static_cast<int>(syscall(SYS_openat2, dirfd, "/i2c-1", &h, sizeof h));
  } else if (strcmp(how, "symlink") == 0) {
    const std::string link = d + "-link";
    unlink(link.c_str());
    if (symlink((d + "/i2c-1").c_str(), link.c_str()) != 0) return 3;
    fd = open(link.c_str(), O_RDWR);
    unlink(link.c_str());
  } else if (strcmp(how, "dotdot") == 0) {
    const std::string base = d.substr(d.rfind('/') + 1);
    fd = open((d + "/../" + base + "/./i2c-1").c_str(), O_RDWR);
  } else {
    return 3;
  }
  if (fd < 0) {
    printf("open (%s): %s: reached the kernel\n", how, strerror(errno));
    return 2;
  }
  if (ioctl(fd, I2C_SLAVE, 0x40) != 0) {
    printf("I2C_SLAVE: %s\n", strerror(errno));
    return 3;
  }
  const unsigned char sleep_all[2] = {0x00, 0x31};
  if (write(fd, sleep_all, 2) == 2) {
    printf("MODE1 = 0x31 written through %s\n", how);
    return 1;
  }
  printf("write (%s): %s\n", how, strerror(errno));
  return errno == EPERM ? 0 : 3;
}

int clone_files() {
  const int fd = open("/dev/i2c-1", O_RDWR);
  if (fd < 0 || ioctl(fd, I2C_SLAVE, 0x40) != 0) {
    printf("open/I2C_SLAVE: %s\n", strerror(errno));
    return 3;
  }
  const long child = syscall(SYS_clone, CLONE_FILES | SIGCHLD, 0, 0, 0, 0);
  if (child == 0) {
    close(fd);
    syscall(SYS_exit, 0);
  }
  if (child < 0) return 3;
  int status = 0;
  waitpid(static_cast<pid_t>(child), &status, 0);
  const unsigned char sleep_all[2] = {0x00, 0x31};
  if (write(fd, sleep_all, 2) == 2) {
    printf("MODE1 = 0x31 written on a descriptor the sibling closed\n");
    return 1;
  }
  printf("write after the sibling's close: %s\n", strerror(errno));
  return errno == EBADF ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  setvbuf(stdout, nullptr, _IONBF, 0);
  if (argc == 4 && strcmp(argv[1], "hello") == 0) {
    const int r = hello(argv[2], argv[3]);
    printf("hello as %s: %s\n", argv[3], r == 1 ? "accepted" : "not accepted");
    return r == 1 ? 1 : 0;
  }
  if (argc == 5 && strcmp(argv[1], "loop") == 0) {
    int accepted = 0;
    for (int i = 0; i < atoi(argv[4]); ++i) accepted += hello(argv[2], argv[3]) == 1;
    printf("accepted %d\n", accepted);
    return accepted == 0 ? 0 : 1;
  }
  if (argc == 2 && strcmp(argv[1], "supervisor") == 0) return supervisor();
  if (argc == 2 && strcmp(argv[1], "escape") == 0) return escape();
  if (argc == 2 && strcmp(argv[1], "clone-files") == 0) return clone_files();
  if (argc == 4 && strcmp(argv[1], "open") == 0) return open_other_name(argv[2], argv[3]);
  fprintf(stderr,
          "usage: attack_identity hello|loop SOCKET TASK [N] | supervisor | escape | open HOW "
          "DIR\n");
  return 2;
}
