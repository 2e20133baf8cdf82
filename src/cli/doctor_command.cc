// contego doctor: what this machine has and lacks for contego, one line per
// fact, each problem with the command that fixes it. Reads only: /proc,
// /sys, /dev, the monitor's socket. Exit 0 with no problem, 1 otherwise.
#include <errno.h>
#include <grp.h>
#include <pwd.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fmt/core.h>
#include <fmt/format.h>
#include <fstream>
#include <linux/seccomp.h>
#include <map>
#include <string>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/un.h>
#include <sys/utsname.h>
#include <tuple>
#include <vector>

#include "cli/command.h"

namespace contego::cli {
namespace {

namespace fs = std::filesystem;

class Report {
 public:
  void ok(const std::string& what) { fmt::print("[ ok ] {}\n", what); }
  void note(const std::string& what) { fmt::print("[note] {}\n", what); }
  void warn(const std::string& what, const std::string& fix) {
    fmt::print("[warn] {}\n       fix: {}\n", what, fix);
    ++warnings_;
  }
  void fail(const std::string& what, const std::string& fix) {
    fmt::print("[FAIL] {}\n       fix: {}\n", what, fix);
    ++failures_;
  }
  int failures() const { return failures_; }
  int warnings() const { return warnings_; }

 private:
  int failures_ = 0, warnings_ = 0;
};

// A system file's first line (/proc, /sys: no size to trust, so no
// read_input_file), without the trailing NUL device-tree strings carry.
std::string first_line(const std::string& path) {
  std::ifstream in(path);
  std::string s;
  std::getline(in, s);
  s.erase(std::remove(s.begin(), s.end(), '\0'), s.end());
  return s;
}

// The seccomp supervisor (`contego run`) needs user notification and
// SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV (Linux 5.19).
void check_kernel(Report& r) {
  utsname u{};
  uname(&u);
  int major = 0, minor = 0;
  std::sscanf(u.release, "%d.%d", &major, &minor);
  const bool new_enough = major > 5 || (major == 5 && minor >= 19);
  uint32_t action = SECCOMP_RET_USER_NOTIF;
  const bool notify = syscall(SYS_seccomp, SECCOMP_GET_ACTION_AVAIL, 0, &action) == 0;
  if (new_enough && notify) {
    r.ok(fmt::format("kernel {} ({}): seccomp user notification, Linux >= 5.19 (contego run)",
                     u.release, u.machine));
  } else {
    r.fail(fmt::format("kernel {}: {}", u.release,
                       notify ? "older than 5.19 (no SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV)"
                              : "no seccomp user notification"),
           "run a kernel of Linux 5.19 or later (Debian 12's 6.1, Raspberry Pi OS bookworm's 6.6)");
  }
}

// i2c-dev or contego.ko, the adapters and their nodes' owners.
void check_buses(Report& r) {
  const bool kmod = fs::exists("/sys/module/contego");
  const bool i2c_dev = fs::exists("/sys/class/i2c-dev") || fs::exists("/sys/module/i2c_dev");
  if (kmod)
    r.ok("contego.ko is loaded: it answers on the bus nodes it took (docs/kernel-client.md)");
  if (!i2c_dev && !kmod) {
    r.warn("neither i2c-dev nor contego.ko is loaded: no /dev/i2c-N node can exist",
           "modprobe i2c-dev && echo i2c-dev >/etc/modules-load.d/i2c-dev.conf");
  } else if (i2c_dev) {
    r.ok("i2c-dev is loaded");
  }
  std::vector<std::string> adapters;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/sys/class/i2c-adapter", ec)) {
    adapters.push_back(e.path().filename());
  }
  std::sort(adapters.begin(), adapters.end());
  if (adapters.empty()) {
    r.warn("no I2C adapter on this machine",
           "on a Raspberry Pi: dtparam=i2c_arm=on in /boot/firmware/config.txt, then reboot (the "
           "header's pins 3 and 5 are /dev/i2c-1); elsewhere: the adapter's driver, or "
           "`modprobe i2c-stub chip_addr=0x40` to try contego without hardware");
  }
  const passwd* monitor_user = getpwnam("contego");
  for (const auto& name : adapters) {
    const std::string label = first_line("/sys/class/i2c-adapter/" + name + "/name");
    const std::string node = "/dev/" + name;
    struct stat st {};
    if (stat(node.c_str(), &st) != 0) {
      r.warn(fmt::format("adapter {} ({}) has no node {}", name, label, node),
             "modprobe i2c-dev (the node appears with it)");
      continue;
    }
    const passwd* owner = getpwuid(st.st_uid);
    const group* grp = getgrgid(st.st_gid);
    const std::string who =
        fmt::format("{}:{} mode {:04o}", owner ? owner->pw_name : std::to_string(st.st_uid),
                    grp ? grp->gr_name : std::to_string(st.st_gid), st.st_mode & 07777);
    const bool others = (st.st_mode & 0006) != 0;
    const bool monitors = monitor_user != nullptr && st.st_uid == monitor_user->pw_uid &&
                          (st.st_mode & 0066) == (st.st_mode & 0060) &&
                          (grp == nullptr || std::strcmp(grp->gr_name, "contego") == 0);
    const std::string what = fmt::format("{} ({}): {}", node, label, who);
    if (kmod && major(st.st_rdev) == 89 && others) {
      r.ok(what + " (contego.ko's node: it decides per call)");
    } else if (monitors) {
      r.ok(what + " (the monitor's alone)");
    } else if (st.st_uid == 0 && (st.st_mode & 0066) == 0) {
      r.ok(what + " (root's alone; give it to the monitor's user when the package is installed)");
    } else {
      r.warn(what + ": users other than the monitor's can open it and bypass contego",
             monitor_user != nullptr
                 ? "udevadm trigger --subsystem-match=i2c-dev (the package's udev rule gives the "
                   "nodes to user contego, mode 0660)"
                 : "install the contego package (its udev rule gives the nodes to the monitor's "
                   "user), or chown root:root and chmod 0600 the node");
    }
  }
}

// Who, besides root, may open `st`'s node: its group's members (named, or
// primary) when the group may read or write it, "everyone" when others may.
std::vector<std::string> who_else_opens(const struct stat& st) {
  if ((st.st_mode & 0006) != 0) return {"everyone"};
  std::vector<std::string> users;
  if ((st.st_mode & 0060) == 0 || st.st_gid == 0) return users;
  if (const group* g = getgrgid(st.st_gid)) {
    for (char** m = g->gr_mem; m != nullptr && *m != nullptr; ++m) users.emplace_back(*m);
  }
  setpwent();
  while (const passwd* pw = getpwent()) {
    if (pw->pw_gid == st.st_gid && pw->pw_uid != 0) users.emplace_back(pw->pw_name);
  }
  endpwent();
  std::sort(users.begin(), users.end());
  users.erase(std::unique(users.begin(), users.end()), users.end());
  return users;
}

// Nodes that reach the bus without i2c-dev: physical memory and I/O ports,
// and the GPIO controller, whose pins include the bus's own (the Pi's
// header I2C is GPIO2/GPIO3). A user who can open one can bit-bang the bus
// or write the controller's registers, and no checker ever sees it; the
// current GoPiGo library does so by default (its bus "RPI_1SW").
void check_bus_bypasses(Report& r) {
  std::vector<std::string> nodes{"/dev/mem", "/dev/kmem", "/dev/port"};
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/dev", ec)) {
    const std::string name = e.path().filename();
    if (name.rfind("gpiomem", 0) == 0 || name.rfind("gpiochip", 0) == 0) nodes.push_back(e.path());
  }
  std::sort(nodes.begin(), nodes.end());
  // One line per way in: the nodes of one kind a group (or everyone) opens.
  struct Way {
    std::vector<std::string> nodes, users;
    std::string group;
  };
  std::map<std::tuple<bool, gid_t, unsigned>, Way> ways;  // GPIO or not, group, mode
  std::vector<std::string> root_only;
  for (const auto& node : nodes) {
    struct stat st {};
    if (stat(node.c_str(), &st) != 0 || !S_ISCHR(st.st_mode)) continue;
    std::vector<std::string> users = who_else_opens(st);
    if (users.empty()) {
      root_only.push_back(node);
      continue;
    }
    const group* grp = getgrgid(st.st_gid);
    const bool gpio = node.find("gpio") != std::string::npos;
    Way& way = ways[{gpio, st.st_gid, st.st_mode & 07777}];
    way.nodes.push_back(node);
    way.users = std::move(users);
    way.group = grp ? grp->gr_name : std::to_string(st.st_gid);
  }
  if (!root_only.empty()) r.ok(fmt::format("{}: only root opens them", fmt::join(root_only, ", ")));
  for (const auto& [kind, way] : ways) {
    const auto& [gpio, gid, mode] = kind;
    r.warn(fmt::format("{} (group {}, mode {:04o}): {} can {} and bypass contego",
                       fmt::join(way.nodes, ", "), way.group, mode, fmt::join(way.users, ", "),
                       gpio ? "drive the bus's pins themselves (a bit-banged bus is never checked)"
                            : "write the bus controller's registers"),
           way.users.front() == "everyone"
               ? fmt::format("chmod o-rw {}", fmt::join(way.nodes, " "))
               : fmt::format("keep the robot's task users out of group {} (gpasswd -d USER {}); "
                             "a program that bit-bangs the bus must use /dev/i2c-N instead "
                             "(the GoPiGo library: set_bus(\"RPI_1\"))",
                             way.group, way.group));
  }
}

// Raspberry Pi: the header's I2C is off until config.txt turns it on.
void check_raspberry_pi(Report& r) {
  const std::string model = first_line("/proc/device-tree/model");
  if (model.find("Raspberry Pi") == std::string::npos) return;
  r.note(model);
  for (const char* path : {"/boot/firmware/config.txt", "/boot/config.txt"}) {
    std::ifstream in(path);
    if (!in) continue;
    bool on = false;
    for (std::string line; std::getline(in, line);) {
      line.erase(std::remove_if(line.begin(), line.end(), ::isspace), line.end());
      if (line.rfind("dtparam=i2c_arm=on", 0) == 0 || line.rfind("dtparam=i2c=on", 0) == 0)
        on = true;
    }
    if (on) {
      r.ok(fmt::format("{}: dtparam=i2c_arm=on (the header's I2C, /dev/i2c-1)", path));
    } else {
      r.warn(fmt::format("{}: the header's I2C is not turned on", path),
             fmt::format("add dtparam=i2c_arm=on to {} and reboot (or raspi-config, Interface "
                         "Options, I2C)",
                         path));
    }
    return;
  }
}

// The monitor daemon and its audit directory (the package's unit).
void check_monitor(Report& r, const std::string& socket_path) {
  if (getpwnam("contego") == nullptr) {
    r.note("no user `contego`: the package is not installed (the monitor's unit runs as it)");
  }
  struct stat st {};
  if (stat(socket_path.c_str(), &st) != 0) {
    r.note(
        fmt::format("no monitor socket at {}: start one with `systemctl enable --now "
                    "contego-monitor` (docs/deployment.md) or use contego run --policy",
                    socket_path));
  } else {
    const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", socket_path.c_str());
    const bool up = fd >= 0 && connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    const int err = errno;
    if (fd >= 0) close(fd);
    if (up) {
      r.ok(fmt::format("a monitor answers at {}", socket_path));
    } else if (err == EACCES) {
      r.note(
          fmt::format("a monitor socket at {}, not open to this user (group contego-client "
                      "may connect)",
                      socket_path));
    } else {
      r.fail(
          fmt::format("{} exists but no monitor answers ({})", socket_path, std::strerror(err)),
          "systemctl restart contego-monitor; journalctl -u contego-monitor says why it stopped");
    }
  }
  const char* audit_dir = "/var/log/contego";
  if (stat(audit_dir, &st) == 0) {
    const passwd* owner = getpwuid(st.st_uid);
    r.ok(fmt::format("audit directory {} ({}, mode {:04o})", audit_dir,
                     owner ? owner->pw_name : std::to_string(st.st_uid), st.st_mode & 07777));
  } else if (getpwnam("contego") != nullptr) {
    r.warn(fmt::format("no audit directory {}", audit_dir),
           "systemd-tmpfiles --create contego.conf (the package's tmpfiles entry makes it)");
  }
}

}  // namespace

void register_doctor(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "doctor", "Say what this machine has and lacks for contego, each problem with its fix");
  auto socket = std::make_shared<std::string>("/run/contego/monitor.sock");
  cmd->add_option("--socket", *socket, "the monitor's socket")->capture_default_str();
  cmd->callback([socket] {
    Report r;
    check_kernel(r);
    check_buses(r);
    check_bus_bypasses(r);
    check_raspberry_pi(r);
    check_monitor(r, *socket);
    fmt::print("{} problem(s), {} warning(s)\n", r.failures(), r.warnings());
    set_exit_code(r.failures() > 0 ? 1 : 0);
  });
}

}  // namespace contego::cli
