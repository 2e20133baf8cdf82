// The gripper of arm.policy (PCA9685 at 0x40 on i2c-1) tries what the
// checker's model of the chip could get wrong:
//  - I2C_RDWR whose first message is allowed (channel 3 to 300, then the
//    gripper's first pulse, 420) and whose second is forbidden (PRE_SCALE):
//    nothing may act, and the model must not keep the first message's
//    effects (shadow, sequence step);
//  - the LED0 write `06 00 00 77 01` sent to the general-call address 0x00,
//    which every PCA9685 takes as a software reset;
//  - writes to the reserved address 0x78 and to an undeclared 10-bit address.
// Then, in a new job, the gripper's first pulse (420) alone: allowed only if
// the refused transfer left the sequence where it was. Prints
// "<step> <result> <errno>" per step.
#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>

namespace {

void report(const char* what, long r) {
  std::printf("%s %ld %d\n", what, r, r < 0 ? errno : 0);
  std::fflush(stdout);
}

long rdwr(int fd, i2c_msg* msgs, unsigned count) {
  i2c_rdwr_ioctl_data data{msgs, count};
  return ioctl(fd, I2C_RDWR, &data);
}

// One write message of `len` bytes to `addr`.
i2c_msg write_msg(uint16_t addr, uint8_t* bytes, uint16_t len, uint16_t flags = 0) {
  return i2c_msg{addr, flags, len, bytes};
}

// A new job: arm.policy's gripper has a 1 s period; the monitor ends a job
// at a sleep that starts half a period or more after the job began, and a
// client that sees no sleeps falls back to windows of one period.
void next_job() {
  usleep(1050 * 1000);
  usleep(1000);
}

}  // namespace

int main() {
  const int fd = open("/dev/i2c-1", O_RDWR);
  if (fd < 0) {
    report("open", fd);
    return 2;
  }
  usleep(1000);                                             // the first job starts here
  uint8_t led3[] = {0x06 + 4 * 3, 0x00, 0x00, 0x2C, 0x01};  // LED3: on 0, off 300
  uint8_t grip[] = {0x06 + 4 * 5, 0x00, 0x00, 0xA4, 0x01};  // LED5: on 0, off 420
  uint8_t prescale[] = {0xFE, 0x03};                        // the gripper may not
  i2c_msg first[2] = {write_msg(0x40, led3, sizeof led3), write_msg(0x40, prescale, 2)};
  report("rdwr-led3-prescale", rdwr(fd, first, 2));
  next_job();
  i2c_msg second[2] = {write_msg(0x40, grip, sizeof grip), write_msg(0x40, prescale, 2)};
  report("rdwr-grip-prescale", rdwr(fd, second, 2));
  next_job();

  uint8_t led0[] = {0x06, 0x00, 0x00, 0x77, 0x01};  // `06 ...`: a software reset at 0x00
  i2c_msg general = write_msg(0x00, led0, sizeof led0);
  report("general-call", rdwr(fd, &general, 1));
  uint8_t mode2[] = {0x01, 0x04};
  i2c_msg reserved = write_msg(0x78, mode2, sizeof mode2);
  report("reserved", rdwr(fd, &reserved, 1));
  i2c_msg ten = write_msg(0x040, mode2, sizeof mode2, I2C_M_TEN);
  report("ten-bit", rdwr(fd, &ten, 1));

  long r = ioctl(fd, I2C_SLAVE, 0x40);
  if (r == 0) r = write(fd, grip, sizeof grip);
  report("pulse", r);
  close(fd);
  return 0;
}
