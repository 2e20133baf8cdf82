// A task allowed to read a device sends its register reads (and a write) with
// i2c_msg flags outside contego's allow-list (contego/i2c_msg_flags.h). On an
// adapter that honours them (a bit-banged one, I2C_FUNC_PROTOCOL_MANGLING),
// I2C_M_REV_DIR_ADDR turns a read into a write the checker never saw, and
// I2C_M_NOSTART glues a message onto the one before it. Each must be refused
// with EINVAL before anything reaches the bus; then a plain register read
// must still work. Prints "<step> <result> <errno>" per step.
// Usage: attack_msg_flags [DEVICE [ADDRESS [reads]]]   (default /dev/i2c-1 0x40;
// "reads": the reads only, as the test bed runs it on a bare adapter)
#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>

namespace {

void report(const char* step, const char* flag, long r) {
  std::printf("%s-%s %ld %d\n", step, flag, r, r < 0 ? errno : 0);
  std::fflush(stdout);
}

long rdwr(int fd, i2c_msg* msgs, unsigned count) {
  i2c_rdwr_ioctl_data data{msgs, count};
  return ioctl(fd, I2C_RDWR, &data);
}

struct Flag {
  const char* name;
  uint16_t bit;
};

// Every bit <linux/i2c.h> defines beyond RD, TEN and RECV_LEN, and one it
// does not define.
constexpr Flag kFlags[] = {
    {"nostart", I2C_M_NOSTART},
    {"rev-dir-addr", I2C_M_REV_DIR_ADDR},
    {"ignore-nak", I2C_M_IGNORE_NAK},
    {"no-rd-ack", I2C_M_NO_RD_ACK},
    {"stop", I2C_M_STOP},
    {"dma-safe", 0x0200},
    {"unknown", 0x0100},
};

}  // namespace

int main(int argc, char** argv) {
  const char* node = argc > 1 ? argv[1] : "/dev/i2c-1";
  const auto addr = static_cast<uint16_t>(argc > 2 ? std::strtoul(argv[2], nullptr, 0) : 0x40);
  const bool reads_only = argc > 3 && std::strcmp(argv[3], "reads") == 0;
  const int fd = open(node, O_RDWR);
  if (fd < 0) {
    report("open", "node", fd);
    return 2;
  }
  // The register the mangled reads point at: 0xFF (a PCA9685's TestMode
  // register, which must never be written). A read of two bytes with
  // I2C_M_REV_DIR_ADDR is clocked as a write of 0xFF 0xFF there.
  for (const Flag& f : kFlags) {
    uint8_t reg = 0xFF;
    uint8_t got[2] = {0, 0};
    i2c_msg read[2] = {{addr, 0, 1, &reg},
                       {addr, static_cast<uint16_t>(I2C_M_RD | f.bit), sizeof got, got}};
    report("read", f.name, rdwr(fd, read, 2));
    uint8_t lone[2] = {0, 0};
    i2c_msg lone_read{addr, static_cast<uint16_t>(I2C_M_RD | f.bit), sizeof lone, lone};
    report("lone-read", f.name, rdwr(fd, &lone_read, 1));
    if (reads_only) continue;
    uint8_t bytes[2] = {0xFF, 0xFF};
    i2c_msg write{addr, f.bit, sizeof bytes, bytes};
    report("write", f.name, rdwr(fd, &write, 1));
  }
  // The same read without the flag: allowed, the register's value comes back.
  uint8_t reg = 0x00;
  uint8_t mode1 = 0;
  i2c_msg plain[2] = {{addr, 0, 1, &reg}, {addr, I2C_M_RD, 1, &mode1}};
  report("read", "plain", rdwr(fd, plain, 2));
  std::printf("mode1 0x%02x\n", mode1);
  return 0;
}
