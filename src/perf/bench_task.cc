// contego-bench-task: the control task `contego bench` times. Opens the bus,
// addresses one device and sends the same command TRIALS times, timing each
// write() with CLOCK_MONOTONIC (the paper's method: measured inside the task,
// so the figure includes whatever enclave client it runs under).
//
//   contego-bench-task BUS ADDR HEXBYTES[,HEXBYTES...] TRIALS OUT PERIOD_US [PER_JOB | BURST_MS]
//   contego-bench-task BUS ADDR HEXBYTES[,HEXBYTES...] JOBS OUT PERIOD_US PER_JOB GRID_NS
//
// OUT receives TRIALS native-endian uint64 nanosecond figures. Several
// commands are sent in turn (a job's sequence). PERIOD_US > 0 without
// PER_JOB sleeps to the next period before each command (a periodic task);
// with PER_JOB, it pauses PERIOD_US before every PER_JOB commands (a
// relative sleep, so every pause is long enough to end a job at the monitor
// however late the job before it ran); 0 sends back to back. TRIALS = 0 sends the first command
// back to back for BURST_MS milliseconds and writes the number of commands sent (the DoS load).
// The second form is the per-job bench's periodic task (perf/per_job.h): a
// job of PER_JOB commands (the HEXBYTES in turn) released every PERIOD_US
// on the grid through GRID_NS (CLOCK_MONOTONIC, absolute sleeps; see
// perf/release.h); OUT receives JOBS job times, each from the job's wake-up
// to the end of its last write(), then the first job's release instant.
// Exit status: 0, 1 on bad arguments or I/O errors, 2 if any write failed.
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <cstdint>
#include <linux/i2c-dev.h>
#include <sys/ioctl.h>
#include <vector>

#include "base/unique_fd.h"
#include "perf/release.h"

namespace {

using contego::monotonic_ns;
using contego::base::UniqueFd;

bool parse_hex(const char* text, std::vector<uint8_t>* out) {
  const size_t n = strlen(text);
  if (n == 0 || n % 2 != 0) return false;
  for (size_t i = 0; i < n; i += 2) {
    char pair[3] = {text[i], text[i + 1], 0};
    char* end = nullptr;
    const long v = strtol(pair, &end, 16);
    if (*end != 0) return false;
    out->push_back(static_cast<uint8_t>(v));
  }
  return true;
}

// HEXBYTES[,HEXBYTES...]: the commands of a job, in order.
bool parse_commands(char* text, std::vector<std::vector<uint8_t>>* commands) {
  for (char* part = strtok(text, ","); part != nullptr; part = strtok(nullptr, ",")) {
    commands->emplace_back();
    if (!parse_hex(part, &commands->back())) {
      fprintf(stderr, "bench task: bad HEXBYTES '%s'\n", part);
      return false;
    }
  }
  return true;
}

bool write_samples(const char* path, const std::vector<uint64_t>& ns) {
  FILE* out = fopen(path, "wb");
  if (out == nullptr || fwrite(ns.data(), sizeof(uint64_t), ns.size(), out) != ns.size() ||
      fclose(out) != 0) {
    perror(path);
    return false;
  }
  return true;
}

UniqueFd open_device(const char* bus, long addr) {
  UniqueFd fd(open(bus, O_RDWR));
  if (!fd.valid()) {
    perror(bus);
    return {};
  }
  if (ioctl(fd.get(), I2C_SLAVE, addr) < 0) {
    perror("I2C_SLAVE");
    return {};
  }
  return fd;
}

// BUS ADDR HEXBYTES,... JOBS OUT PERIOD_US PER_JOB GRID_NS
int per_job(char** argv) {
  const long addr = strtol(argv[2], nullptr, 0);
  std::vector<std::vector<uint8_t>> commands;
  if (!parse_commands(argv[3], &commands)) return 1;
  const long jobs = strtol(argv[4], nullptr, 10);
  const long period_us = strtol(argv[6], nullptr, 10);
  const long per_job = strtol(argv[7], nullptr, 10);
  const unsigned long long grid = strtoull(argv[8], nullptr, 10);
  if (commands.empty() || jobs < 1 || period_us < 1 || per_job < 1 || addr <= 0 || addr > 0x7F) {
    fprintf(stderr, "bench task: bad HEXBYTES, JOBS, PERIOD_US, PER_JOB or ADDR\n");
    return 1;
  }
  UniqueFd fd = open_device(argv[1], addr);
  if (!fd.valid()) return 1;
  std::vector<uint64_t> ns(static_cast<size_t>(jobs));
  const uint64_t period_ns = static_cast<uint64_t>(period_us) * 1000u;
  const uint64_t first = contego::perf::start_grid(grid, period_ns);
  long failed = 0;
  for (long j = 0; j < jobs; ++j) {
    contego::perf::sleep_until_ns(first + static_cast<uint64_t>(j) * period_ns);
    const uint64_t t0 = monotonic_ns();
    for (long i = 0; i < per_job; ++i) {
      const std::vector<uint8_t>& c = commands[static_cast<size_t>(i) % commands.size()];
      if (write(fd.get(), c.data(), c.size()) != static_cast<ssize_t>(c.size())) ++failed;
    }
    ns[static_cast<size_t>(j)] = monotonic_ns() - t0;
  }
  fd.reset();  // done with the device before the samples are written
  // Then when job 0 was released: the others follow on the grid.
  ns.push_back(first);
  if (!write_samples(argv[5], ns)) return 1;
  if (failed > 0) fprintf(stderr, "bench task: %ld writes failed\n", failed);
  return failed > 0 ? 2 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 9) return per_job(argv);
  if (argc != 7 && argc != 8) {
    fprintf(stderr,
            "usage: %s BUS ADDR HEXBYTES[,HEXBYTES...] TRIALS OUT PERIOD_US [PER_JOB | BURST_MS]\n",
            argv[0]);
    return 1;
  }
  const long addr = strtol(argv[2], nullptr, 0);
  std::vector<std::vector<uint8_t>> commands;
  if (!parse_commands(argv[3], &commands)) return 1;
  if (commands.empty()) {
    fprintf(stderr, "bench task: no command\n");
    return 1;
  }
  const std::vector<uint8_t>& bytes = commands.front();
  const long trials = strtol(argv[4], nullptr, 10);
  const long period_us = strtol(argv[6], nullptr, 10);
  const long per_job = trials > 0 && argc == 8 ? strtol(argv[7], nullptr, 10) : 1;
  if (trials < 0 || period_us < 0 || addr <= 0 || addr > 0x7F || per_job < 1) {
    fprintf(stderr, "bench task: bad TRIALS, PERIOD_US, PER_JOB or ADDR\n");
    return 1;
  }
  UniqueFd fd = open_device(argv[1], addr);
  if (!fd.valid()) return 1;
  int failed = 0;
  if (trials == 0) {  // the burst
    const uint64_t end =
        monotonic_ns() + static_cast<uint64_t>(argc == 8 ? atol(argv[7]) : 0) * 1000000u;
    long sent = 0;
    while (monotonic_ns() < end) {
      if (write(fd.get(), bytes.data(), bytes.size()) != static_cast<ssize_t>(bytes.size())) {
        ++failed;
      }
      ++sent;
    }
    FILE* out = fopen(argv[5], "wb");
    const uint64_t count = static_cast<uint64_t>(sent);
    if (out == nullptr || fwrite(&count, sizeof count, 1, out) != 1 || fclose(out) != 0) return 1;
    return 0;
  }
  std::vector<uint64_t> ns(static_cast<size_t>(trials));
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (long i = 0; i < trials; ++i) {
    if (period_us > 0 && argc == 8 && i % per_job == 0) {
      const timespec pause{period_us / 1000000, (period_us % 1000000) * 1000};
      timespec left = pause;
      while (nanosleep(&left, &left) != 0 && errno == EINTR) {
      }
    } else if (period_us > 0 && argc != 8) {
      next.tv_nsec += period_us * 1000;
      while (next.tv_nsec >= 1000000000) {
        next.tv_nsec -= 1000000000;
        ++next.tv_sec;
      }
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
      }
    }
    const std::vector<uint8_t>& command = commands[static_cast<size_t>(i) % commands.size()];
    const uint64_t t0 = monotonic_ns();
    const ssize_t r = write(fd.get(), command.data(), command.size());
    const uint64_t t1 = monotonic_ns();
    if (r != static_cast<ssize_t>(command.size())) ++failed;
    ns[static_cast<size_t>(i)] = t1 - t0;
  }
  fd.reset();  // done with the device before the samples are written
  if (!write_samples(argv[5], ns)) return 1;
  if (failed > 0) fprintf(stderr, "bench task: %d of %ld writes failed\n", failed, trials);
  return failed > 0 ? 2 : 0;
}
