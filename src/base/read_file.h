// Reading an input file a user names (policy, policy test, image, task set,
// scenario, audit log). Only regular files are read, and whole-file reads
// are bounded: `/dev/zero` would otherwise be read forever, a FIFO would
// block, and a directory would read as an empty (valid) policy.
#ifndef CONTEGO_BASE_READ_FILE_H_
#define CONTEGO_BASE_READ_FILE_H_

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <string>
#include <sys/stat.h>

#include "base/result.h"
#include "base/unique_fd.h"

namespace contego {

// Far above any policy, test file or image (a policy image holds at most a
// few hundred KiB), far below what would hurt a small board.
inline constexpr size_t kMaxInputFileBytes = 16u << 20;

// What a file of `mode` is, for a message that refuses anything but a regular
// file: "a directory", "a FIFO", ...
inline const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

namespace detail {

// Opens `path` for reading if it is a regular file. O_NONBLOCK so that
// opening a FIFO does not wait for a writer before it can be refused.
inline Result<base::UniqueFd> open_regular(const std::string& path) {
  base::UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY));
  if (!fd.valid()) return make_error(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) {
    return make_error(path + ": is " + file_kind(st.st_mode) + "; expected a regular file");
  }
  return fd;
}

}  // namespace detail

// Ok when `path` names a regular file this process can open for reading;
// otherwise a message naming the path and what it is.
inline Status require_regular_file(const std::string& path) {
  if (Result<base::UniqueFd> fd = detail::open_regular(path); !fd) return make_error(fd.error());
  return {};
}

// The whole of a regular file of at most `max_bytes` bytes.
inline Result<std::string> read_input_file(const std::string& path,
                                           size_t max_bytes = kMaxInputFileBytes) {
  Result<base::UniqueFd> fd = detail::open_regular(path);
  if (!fd) return make_error(fd.error());
  std::string text;
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd->get(), buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return make_error(path + ": read error: " + std::strerror(errno));
    if (n == 0) break;
    if (text.size() + static_cast<size_t>(n) > max_bytes) {
      return make_error(path + ": larger than " + std::to_string(max_bytes) +
                        " bytes; expected a smaller file");
    }
    text.append(buf, static_cast<size_t>(n));
  }
  return text;
}

}  // namespace contego

#endif  // CONTEGO_BASE_READ_FILE_H_
