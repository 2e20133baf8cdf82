#include "intercept/seccomp/bus_path.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <deque>
#include <linux/magic.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <sys/sysmacros.h>
#include <vector>

#include "base/unique_fd.h"

namespace contego::intercept::seccomp {
namespace {

using base::UniqueFd;

// openat2's resolve flags this code knows (linux/openat2.h).
constexpr uint64_t kResolveInRoot = 0x10;
constexpr uint64_t kKnownResolve = 0x3f;
constexpr int kMaxLinks = 40;

std::string read_link(const std::string& link) {
  char buf[PATH_MAX];
  const ssize_t n = readlink(link.c_str(), buf, sizeof buf - 1);
  if (n < 0) return {};
  return std::string(buf, static_cast<size_t>(n));
}

std::string read_link_at(int dirfd, const std::string& name) {
  char buf[PATH_MAX];
  const ssize_t n = readlinkat(dirfd, name.c_str(), buf, sizeof buf - 1);
  if (n < 0) return {};
  return std::string(buf, static_cast<size_t>(n));
}

pid_t thread_group_of(pid_t tid) {
  const UniqueFd fd(
      open(("/proc/" + std::to_string(tid) + "/status").c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd.valid()) return tid;
  char buf[1024];
  const ssize_t n = read(fd.get(), buf, sizeof buf - 1);
  if (n <= 0) return tid;
  buf[n] = 0;
  const char* at = strstr(buf, "\nTgid:");
  return at != nullptr ? static_cast<pid_t>(atoi(at + 6)) : tid;
}

std::vector<std::string> components(const std::string& path) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i <= path.size()) {
    size_t j = path.find('/', i);
    if (j == std::string::npos) j = path.size();
    if (j > i) out.push_back(path.substr(i, j - i));
    i = j + 1;
  }
  return out;
}

bool same_file(int a, int b) {
  struct stat sa {
  }, sb{};
  return fstat(a, &sa) == 0 && fstat(b, &sb) == 0 && sa.st_dev == sb.st_dev &&
         sa.st_ino == sb.st_ino;
}

bool is_procfs_root(int fd) {
  struct statfs fs {};
  struct stat st {};
  return fstatfs(fd, &fs) == 0 && fs.f_type == PROC_SUPER_MAGIC && fstat(fd, &st) == 0 &&
         st.st_ino == 1;
}

bool on_procfs(int fd) {
  struct statfs fs {};
  return fstatfs(fd, &fs) == 0 && fs.f_type == PROC_SUPER_MAGIC;
}

// Walks `path` from `start` (or `root` for an absolute path) as the kernel
// would for the program; returns the final O_PATH descriptor or -1.
int walk(UniqueFd root, UniqueFd start, const std::string& path, pid_t tid, bool nofollow) {
  std::deque<std::string> todo;
  for (auto& c : components(path)) todo.push_back(std::move(c));
  UniqueFd cur(dup(path.size() > 0 && path[0] == '/' ? root.get() : start.get()));
  int links = 0;
  pid_t tgid = 0;
  while (!todo.empty() && cur.valid()) {
    std::string name = std::move(todo.front());
    todo.pop_front();
    if (name == ".") continue;
    if (name == "..") {
      if (!same_file(cur.get(), root.get())) {
        cur = UniqueFd(openat(cur.get(), "..", O_PATH | O_CLOEXEC));
      }
      continue;
    }
    if ((name == "self" || name == "thread-self") && is_procfs_root(cur.get())) {
      if (tgid == 0) tgid = thread_group_of(tid);
      if (name == "thread-self") {
        todo.push_front(std::to_string(tid));
        todo.push_front("task");
      }
      name = std::to_string(tgid);
    }
    UniqueFd next(openat(cur.get(), name.c_str(), O_PATH | O_NOFOLLOW | O_CLOEXEC));
    if (!next.valid()) return -1;
    struct stat st {};
    if (fstat(next.get(), &st) != 0) return -1;
    if (!S_ISLNK(st.st_mode)) {
      cur = std::move(next);
      continue;
    }
    if (todo.empty() && nofollow) return -1;  // the kernel refuses it (ELOOP)
    if (++links > kMaxLinks) return -1;
    const std::string target = read_link_at(cur.get(), name);
    // A procfs magic link (cwd, root, exe, fd/N: its text is absolute or a
    // `type:[inode]` name): the kernel follows it to the program's object.
    const bool magic = on_procfs(cur.get()) && (target.empty() || target[0] == '/' ||
                                                target.find(':') != std::string::npos);
    if (magic) {
      cur = UniqueFd(openat(cur.get(), name.c_str(), O_PATH | O_CLOEXEC));
      continue;
    }
    // An ordinary link (or procfs's own relative ones, `mounts` -> `self/mounts`).
    auto parts = components(target);
    for (auto it = parts.rbegin(); it != parts.rend(); ++it) todo.push_front(*it);
    if (!target.empty() && target[0] == '/') cur = UniqueFd(dup(root.get()));
  }
  return cur.release();
}

}  // namespace

BusPath resolve_bus_path(pid_t tid, int dirfd, const std::string& path, uint64_t resolve,
                         bool nofollow) {
  if (path.empty()) return {};
  if ((resolve & ~kKnownResolve) != 0) return {-1, EINVAL};
  const std::string proc = "/proc/" + std::to_string(tid);
  const std::string base_link =
      dirfd == AT_FDCWD ? proc + "/cwd" : proc + "/fd/" + std::to_string(dirfd);
  const bool in_root = (resolve & kResolveInRoot) != 0;
  // By name.
  std::string full = path;
  if (path[0] != '/' || in_root) {
    const std::string base = read_link(base_link);
    if (!base.empty()) full = base + "/" + path;
  }
  std::string lexical = lexical_normalise(full);
  for (const char* self : {"/proc/self", "/proc/thread-self"}) {
    const std::string prefix = self;
    if (lexical == prefix || lexical.rfind(prefix + "/", 0) == 0) {
      const std::string own =
          prefix == "/proc/self"
              ? "/proc/" + std::to_string(thread_group_of(tid))
              : "/proc/" + std::to_string(thread_group_of(tid)) + "/task/" + std::to_string(tid);
      lexical = own + lexical.substr(prefix.size());
    }
  }
  if (int n = bus_number(lexical); n >= 0) return {n, 0};
  // By what the kernel resolves.
  UniqueFd start(open(base_link.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC));
  if (!start.valid()) return {};
  UniqueFd root(in_root ? dup(start.get())
                        : open((proc + "/root").c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC));
  if (!root.valid()) return {};
  UniqueFd end(walk(std::move(root), std::move(start), path, tid, nofollow));
  struct stat st {};
  if (!end.valid() || fstat(end.get(), &st) != 0) return {};
  if (S_ISCHR(st.st_mode) && major(st.st_rdev) == kI2cDevMajor && minor(st.st_rdev) <= 255) {
    return {static_cast<int>(minor(st.st_rdev)), 0};
  }
  return {};
}

}  // namespace contego::intercept::seccomp
