// The monitor's readiness and liveness for systemd (Type=notify units):
// READY=1 once it serves, WATCHDOG=1 every half WatchdogSec from then on,
// STOPPING=1 as it stops. Through libsystemd's sd_notify when contego is
// built with it (CONTEGO_SYSTEMD, the package is); otherwise, and when not
// started by systemd ($NOTIFY_SOCKET unset), these do nothing.
#ifndef CONTEGO_CLI_SYSTEMD_NOTIFY_H_
#define CONTEGO_CLI_SYSTEMD_NOTIFY_H_

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace contego::cli {

class SystemdNotifier {
 public:
  SystemdNotifier() = default;
  ~SystemdNotifier();  // stops the watchdog thread
  SystemdNotifier(const SystemdNotifier&) = delete;
  SystemdNotifier& operator=(const SystemdNotifier&) = delete;

  // READY=1 with a status line; starts the watchdog pings if systemd asked for them.
  void ready(const std::string& status);
  // STOPPING=1; ends the watchdog pings.
  void stopping(const std::string& status);

 private:
  void stop_watchdog();
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;  // mu_
  std::thread watchdog_;
};

}  // namespace contego::cli

#endif  // CONTEGO_CLI_SYSTEMD_NOTIFY_H_
