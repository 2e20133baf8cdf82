// A program interrupted by signals while its bus writes are being checked:
// a timer fires every 20 µs during 3000 writes of PCA9685 register 0x06.
// Each write must act exactly once and only when it reports success: the
// test compares the program's count of successful writes with the allowed
// decisions in the audit log. argv[1]: "restart" installs the handler with
// SA_RESTART (an interrupted call is re-issued), "eintr" without it (the
// call fails with EINTR and the program does not retry it).
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <linux/i2c-dev.h>
#include <sys/ioctl.h>
#include <sys/time.h>

static volatile sig_atomic_t signals = 0;
static void on_alarm(int) { signals = signals + 1; }

int main(int argc, char** argv) {
  const bool restart = argc > 1 && strcmp(argv[1], "restart") == 0;
  const int fd = open("/dev/i2c-1", O_RDWR);
  if (fd < 0 || ioctl(fd, I2C_SLAVE, 0x40) != 0) {
    printf("cannot open the bus: %s\n", strerror(errno));
    return 2;
  }
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_alarm;
  sa.sa_flags = restart ? SA_RESTART : 0;
  sigaction(SIGALRM, &sa, nullptr);
  const itimerval every{{0, 20}, {0, 20}};
  setitimer(ITIMER_REAL, &every, nullptr);
  int ok = 0, eintr = 0, other = 0;
  for (int i = 0; i < 3000; ++i) {
    const unsigned char frame[2] = {0x06, static_cast<unsigned char>(i)};
    const ssize_t n = write(fd, frame, sizeof frame);
    if (n == 2) {
      ++ok;
    } else if (n < 0 && errno == EINTR) {
      ++eintr;
    } else {
      ++other;
    }
  }
  const itimerval off{};
  setitimer(ITIMER_REAL, &off, nullptr);
  printf("ok %d eintr %d other %d signals %d\n", ok, eintr, other, static_cast<int>(signals));
  return other == 0 ? 0 : 1;
}
