#include "monitor/peer_identity.h"

#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <pwd.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fmt/core.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>

#include "base/errorf.h"
#include "base/unique_fd.h"

#ifndef SO_PEERPIDFD
#define SO_PEERPIDFD 77
#endif

namespace contego::monitor {

namespace {

// A numeric id, or nullopt when `text` is not all digits.
std::optional<uint32_t> numeric_id(const std::string& text) {
  if (text.empty() || text.size() > 10) return std::nullopt;
  uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  if (v > UINT32_MAX - 1) return std::nullopt;  // (uid_t)-1 means "no id"
  return static_cast<uint32_t>(v);
}

// A small /proc file, whole ("" if it cannot be read).
std::string read_proc(const std::string& path) {
  const base::UniqueFd fd(open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd.valid()) return {};
  std::string out;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(fd.get(), buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0 || out.size() > 1 << 20) break;
    out.append(buf, static_cast<size_t>(n));
  }
  return out;
}

// A pidfd becomes readable when its process exits; polling needs no
// permission over the process (signal 0 would: another uid's is EPERM).
bool pidfd_alive(int pidfd) {
  pollfd p{pidfd, POLLIN, 0};
  return poll(&p, 1, 0) == 0;
}

// A user or group, by number or by name (`lookup`: the host's database);
// unset, with `unresolved` saying so, when the host has no such name.
template <typename Lookup>
std::optional<uint32_t> resolve_id(const std::string& task, const std::string& name,
                                   const char* what, std::string* unresolved, Lookup lookup) {
  if (auto n = numeric_id(name)) return n;
  std::optional<uint32_t> found = lookup(name.c_str());
  if (!found) *unresolved = fmt::format("task '{}': no {} '{}' on this host", task, what, name);
  return found;
}

}  // namespace

Result<TaskBinding> resolve_binding(const std::string& task, const TaskIdentity& id) {
  TaskBinding b;
  b.sessions = id.sessions == 0 ? 1 : id.sessions;
  b.unit = id.unit;
  b.cgroup = id.cgroup;
  if (!id.user.empty()) {
    b.uid = resolve_id(task, id.user, "user", &b.unresolved, [](const char* name) {
      const passwd* pw = getpwnam(name);
      return pw == nullptr ? std::nullopt : std::optional<uint32_t>(pw->pw_uid);
    });
  }
  if (!id.group.empty()) {
    b.gid = resolve_id(task, id.group, "group", &b.unresolved, [](const char* name) {
      const group* gr = getgrnam(name);
      return gr == nullptr ? std::nullopt : std::optional<uint32_t>(gr->gr_gid);
    });
  }
  if (!id.exe.empty()) {
    struct stat st {};
    if (id.exe[0] != '/') {
      return errorf("task '{}': exe \"{}\" is not an absolute path", task, id.exe);
    }
    if (stat(id.exe.c_str(), &st) != 0) {
      b.unresolved = fmt::format("task '{}': exe \"{}\": {}", task, id.exe, strerror(errno));
    } else if (!S_ISREG(st.st_mode)) {
      b.unresolved = fmt::format("task '{}': exe \"{}\" is not a regular file", task, id.exe);
    }
    b.exe = id.exe;
    b.has_exe = true;
    b.exe_dev = st.st_dev;
    b.exe_ino = st.st_ino;
  }
  if (!b.cgroup.empty() && b.cgroup[0] != '/') {
    return errorf("task '{}': cgroup \"{}\" is not an absolute cgroup path", task, b.cgroup);
  }
  return b;
}

void parse_status(const std::string& status, PeerFacts* f) {
  std::istringstream in(status);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string key;
    fields >> key;
    if (key == "PPid:") {
      fields >> f->ppid;
    } else if (key == "Uid:" || key == "Gid:") {
      uint32_t real = 0, effective = 0;
      fields >> real >> effective;
      (key == "Uid:" ? f->uid : f->gid) = effective;
    } else if (key == "Groups:") {
      f->groups.clear();
      gid_t g;
      while (fields >> g) f->groups.push_back(g);
    }
  }
}

std::string unified_cgroup(const std::string& proc_cgroup) {
  std::istringstream in(proc_cgroup);
  std::string line, systemd;
  while (std::getline(in, line)) {
    if (line.rfind("0::", 0) == 0) return line.substr(3);
    if (const auto at = line.find(":name=systemd:"); at != std::string::npos) {
      systemd = line.substr(at + 14);
    }
  }
  return systemd;
}

int peer_pidfd(int socket_fd, pid_t peer_pid) {
  int pidfd = -1;
  socklen_t len = sizeof pidfd;
  if (getsockopt(socket_fd, SOL_SOCKET, SO_PEERPIDFD, &pidfd, &len) == 0 && pidfd >= 0) {
    return pidfd;
  }
  return static_cast<int>(syscall(SYS_pidfd_open, peer_pid, 0));
}

bool own_exe(dev_t* dev, ino_t* ino) {
  struct stat st {};
  if (stat("/proc/self/exe", &st) != 0) return false;
  *dev = st.st_dev;
  *ino = st.st_ino;
  return true;
}

Result<PeerFacts> process_facts(int pidfd, pid_t pid) {
  PeerFacts f;
  f.pid = pid;
  const std::string dir = "/proc/" + std::to_string(pid);
  const std::string status = read_proc(dir + "/status");
  if (status.empty()) return errorf("process {} is gone", pid);
  parse_status(status, &f);
  f.cgroup = unified_cgroup(read_proc(dir + "/cgroup"));
  struct stat st {};
  if (stat((dir + "/exe").c_str(), &st) == 0) {
    f.exe_known = true;
    f.exe_dev = st.st_dev;
    f.exe_ino = st.st_ino;
    char buf[4096];
    const ssize_t n = readlink((dir + "/exe").c_str(), buf, sizeof buf - 1);
    if (n > 0) f.exe_path.assign(buf, static_cast<size_t>(n));
  }
  // Read after pinning; the files are that process's only if it is still
  // alive now (a number is not reused while its process lives).
  if (!pidfd_alive(pidfd)) return errorf("process {} exited", pid);
  return f;
}

Status binding_mismatch(const std::string& task, const TaskBinding& b, const PeerFacts& f) {
  if (!b.unresolved.empty()) return make_error(b.unresolved + " (no peer can run it)");
  if (b.uid && f.uid != *b.uid) {
    return errorf("task '{}' is bound to uid {}; the peer runs as uid {}", task, *b.uid, f.uid);
  }
  if (b.gid && f.gid != *b.gid &&
      std::find(f.groups.begin(), f.groups.end(), *b.gid) == f.groups.end()) {
    return errorf("task '{}' is bound to group {}; the peer (gid {}) is not in it", task, *b.gid,
                  f.gid);
  }
  if (b.has_exe) {
    if (!f.exe_known) {
      return errorf(
          "task '{}' is bound to exe \"{}\"; the peer's executable cannot be read (a monitor "
          "checking `exe` must be able to read /proc/PID/exe of its peers: root or "
          "CAP_SYS_PTRACE)",
          task, b.exe);
    }
    if (f.exe_dev != b.exe_dev || f.exe_ino != b.exe_ino) {
      return errorf("task '{}' is bound to exe \"{}\"; the peer runs \"{}\"", task, b.exe,
                    f.exe_path);
    }
  }
  if (!b.cgroup.empty()) {
    const bool under = f.cgroup == b.cgroup ||
                       (f.cgroup.size() > b.cgroup.size() && f.cgroup.rfind(b.cgroup, 0) == 0 &&
                        (b.cgroup == "/" || f.cgroup[b.cgroup.size()] == '/'));
    if (!under) {
      return errorf("task '{}' is bound to cgroup \"{}\"; the peer is in \"{}\"", task, b.cgroup,
                    f.cgroup);
    }
  }
  if (!b.unit.empty()) {
    bool in_unit = false;
    std::istringstream parts(f.cgroup);
    std::string part;
    while (std::getline(parts, part, '/')) in_unit = in_unit || part == b.unit;
    if (!in_unit) {
      return errorf("task '{}' is bound to unit {}; the peer is in cgroup \"{}\"", task, b.unit,
                    f.cgroup);
    }
  }
  return {};
}

}  // namespace contego::monitor
