#include "cli/systemd_notify.h"

#include <chrono>
#include <cstdint>

#ifdef CONTEGO_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace contego::cli {
namespace {
void notify(const std::string& state) {
#ifdef CONTEGO_HAVE_SYSTEMD
  sd_notify(0, state.c_str());
#else
  (void)state;
#endif
}

// systemd's WatchdogSec for this process in µs, 0 if none.
uint64_t watchdog_usec() {
#ifdef CONTEGO_HAVE_SYSTEMD
  uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) return usec;
#endif
  return 0;
}
}  // namespace

void SystemdNotifier::ready(const std::string& status) {
  notify("READY=1\nSTATUS=" + status);
  const uint64_t usec = watchdog_usec();
  if (usec == 0 || watchdog_.joinable()) return;
  // The ping says the process is alive and not wedged in this thread's
  // scheduling; the server's own threads are not probed.
  watchdog_ = std::thread([this, period = std::chrono::microseconds(usec / 2)] {
    std::unique_lock<std::mutex> lock(mu_);
    while (!stop_) {
      notify("WATCHDOG=1");
      cv_.wait_for(lock, period, [this] { return stop_; });
    }
  });
}

void SystemdNotifier::stopping(const std::string& status) {
  notify("STOPPING=1\nSTATUS=" + status);
  stop_watchdog();
}

void SystemdNotifier::stop_watchdog() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
}

SystemdNotifier::~SystemdNotifier() { stop_watchdog(); }

}  // namespace contego::cli
