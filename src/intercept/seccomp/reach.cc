#include "intercept/seccomp/reach.h"

#include <limits.h>
#include <stdlib.h>
#include <unistd.h>

#include <sys/prctl.h>
#include <sys/stat.h>

#include "base/mutex.h"

namespace contego::intercept::seccomp {

std::string resolve_program(const std::string& name) {
  auto absolute = [](const std::string& path) {
    if (path.empty() || path[0] == '/') return path;
    char cwd[PATH_MAX];
    return getcwd(cwd, sizeof cwd) != nullptr ? std::string(cwd) + "/" + path : std::string();
  };
  if (name.find('/') != std::string::npos) return absolute(name);
  const char* env = getenv("PATH");
  const std::string path = env != nullptr ? env : "/usr/local/bin:/bin:/usr/bin";
  size_t i = 0;
  while (i <= path.size()) {
    size_t j = path.find(':', i);
    if (j == std::string::npos) j = path.size();
    const std::string dir = j == i ? "." : path.substr(i, j - i);
    const std::string candidate = dir + "/" + name;
    struct stat st {};
    if (stat(candidate.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        access(candidate.c_str(), X_OK) == 0) {
      return absolute(candidate);
    }
    i = j + 1;
  }
  return {};
}

namespace {
base::Mutex dumpable_mu;
int dumpable_users GUARDED_BY(dumpable_mu) = 0;
int dumpable_before GUARDED_BY(dumpable_mu) = 1;
}  // namespace

void enter_undumpable() {
  base::MutexLock lock(dumpable_mu);
  if (dumpable_users++ == 0) {
    dumpable_before = prctl(PR_GET_DUMPABLE, 0, 0, 0, 0);
    prctl(PR_SET_DUMPABLE, 0, 0, 0, 0);
  }
}
void leave_undumpable() {
  base::MutexLock lock(dumpable_mu);
  if (--dumpable_users == 0 && dumpable_before > 0) {
    prctl(PR_SET_DUMPABLE, dumpable_before, 0, 0, 0);
  }
}

}  // namespace contego::intercept::seccomp
