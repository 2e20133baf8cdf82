/* The overhead bench's client: N SMBus byte-data writes (what `i2cset -y BUS
 * ADDR REG VALUE` sends) from one process, each timed with CLOCK_MONOTONIC, as
 * the paper times an actuation command. The same binary runs on the plain
 * adapter and under contego; it prints one line:
 *   loop n=N mean_us=.. median_us=.. p99_us=.. max_us=.. errors=E
 * Usage: i2c-write-loop BUS ADDR REG VALUE N
 */
#include <fcntl.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

static int cmp(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}

int main(int argc, char** argv) {
  if (argc != 6) {
    fprintf(stderr, "usage: %s BUS ADDR REG VALUE N\n", argv[0]);
    return 2;
  }
  char path[32];
  snprintf(path, sizeof path, "/dev/i2c-%s", argv[1]);
  const long addr = strtol(argv[2], NULL, 0), reg = strtol(argv[3], NULL, 0),
             value = strtol(argv[4], NULL, 0), n = strtol(argv[5], NULL, 0);
  if (n <= 0) return 2;
  const int fd = open(path, O_RDWR);
  if (fd < 0 || ioctl(fd, I2C_SLAVE, addr) < 0) {
    perror(path);
    return 1;
  }
  double* us = calloc((size_t)n, sizeof *us);
  if (us == NULL) return 1;
  long errors = 0;
  for (long i = 0; i < n; ++i) {
    union i2c_smbus_data data;
    data.byte = (unsigned char)value;
    struct i2c_smbus_ioctl_data args = {I2C_SMBUS_WRITE, (unsigned char)reg,
                                        I2C_SMBUS_BYTE_DATA, &data};
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    if (ioctl(fd, I2C_SMBUS, &args) < 0) ++errors;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    us[i] = (double)(t1.tv_sec - t0.tv_sec) * 1e6 + (double)(t1.tv_nsec - t0.tv_nsec) / 1e3;
  }
  double sum = 0;
  for (long i = 0; i < n; ++i) sum += us[i];
  qsort(us, (size_t)n, sizeof *us, cmp);
  const long p99 = (n * 99 + 99) / 100 - 1;
  printf("loop n=%ld mean_us=%.1f median_us=%.1f p99_us=%.1f max_us=%.1f errors=%ld\n", n,
         sum / (double)n, us[n / 2], us[p99], us[n - 1], errors);
  close(fd);
  free(us);
  return errors == 0 ? 0 : 1;
}
