// A program interrupted by signals while its bus writes are being checked:
// a timer fires every 20 µs during 3000 writes of PCA9685 register 0x06.
// Each write must act exactly once and only when it reports success: the
// test compares the program's count of successful writes with the allowed
// decisions in the audit log. argv[1]: "restart" installs the handler with
// SA_RESTART (an interrupted call is re-issued), "eintr" without it (the
// call fails with EINTR and the program does not retry it).
//
// With SA_RESTART a write only acts if the supervisor takes the call before
// the next signal withdraws it; where that takes longer than the timer's
// period (an emulated CPU) the write would restart forever. So a write that
// sees 500 signals doubles the period; the period reached is printed.
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <linux/i2c-dev.h>
#include <sys/ioctl.h>

static volatile sig_atomic_t signals = 0;
static volatile sig_atomic_t during_write = 0;  // signals since the current write began
static volatile sig_atomic_t period_us = 20;
static timer_t timer;

static void arm(long us) {
  const itimerspec every{{0, us * 1000}, {0, us * 1000}};
  timer_settime(timer, 0, &every, nullptr);  // async-signal-safe
}

static void on_alarm(int) {
  signals = signals + 1;
  during_write = during_write + 1;
  if (during_write >= 500 && period_us < 100000) {
    period_us = period_us * 2;
    during_write = 0;
    arm(period_us);
  }
}

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
  sigevent ev;
  memset(&ev, 0, sizeof ev);
  ev.sigev_notify = SIGEV_SIGNAL;
  ev.sigev_signo = SIGALRM;
  if (timer_create(CLOCK_MONOTONIC, &ev, &timer) != 0) {
    printf("timer_create: %s\n", strerror(errno));
    return 2;
  }
  arm(period_us);
  int ok = 0, eintr = 0, other = 0;
  for (int i = 0; i < 3000; ++i) {
    const unsigned char frame[2] = {0x06, static_cast<unsigned char>(i)};
    during_write = 0;
    const ssize_t n = write(fd, frame, sizeof frame);
    if (n == 2) {
      ++ok;
    } else if (n < 0 && errno == EINTR) {
      ++eintr;
    } else {
      ++other;
    }
  }
  timer_delete(timer);
  printf("ok %d eintr %d other %d signals %d period_us %d\n", ok, eintr, other,
         static_cast<int>(signals), static_cast<int>(period_us));
  return other == 0 ? 0 : 1;
}
