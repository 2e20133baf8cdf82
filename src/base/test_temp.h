// Temporary files and folders for tests, in the system's temporary folder
// (TMPDIR or /tmp), named `prefix` and a unique suffix. Call them under
// ASSERT_NO_FATAL_FAILURE: failing to make one fails the test.
#ifndef CONTEGO_BASE_TEST_TEMP_H_
#define CONTEGO_BASE_TEST_TEMP_H_

#include <stdlib.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <gtest/gtest.h>
#include <string>

namespace contego::test_support {

inline std::string temp_pattern(const std::string& prefix) {
  return (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
}

// Makes an empty file; its name goes to *path.
inline void make_temp_file(const std::string& prefix, std::string* path) {
  std::string name = temp_pattern(prefix);
  const int fd = mkstemp(name.data());
  ASSERT_GE(fd, 0) << name << ": " << std::strerror(errno);
  close(fd);
  *path = name;
}

// Makes an empty folder; its name goes to *path.
inline void make_temp_dir(const std::string& prefix, std::string* path) {
  std::string name = temp_pattern(prefix);
  ASSERT_NE(mkdtemp(name.data()), nullptr) << name << ": " << std::strerror(errno);
  *path = name;
}

}  // namespace contego::test_support

#endif  // CONTEGO_BASE_TEST_TEMP_H_
