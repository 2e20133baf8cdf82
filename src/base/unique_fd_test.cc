#include "base/unique_fd.h"

#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <utility>

namespace contego::base {
namespace {

bool is_open(int fd) { return fcntl(fd, F_GETFD) != -1; }

TEST(UniqueFd, ClosesWhatItOwnsAndHandsBackWhatItReleases) {
  int fds[2];
  ASSERT_EQ(pipe(fds), 0);
  {
    UniqueFd a(fds[0]);
    UniqueFd b(std::move(a));
    EXPECT_FALSE(a.valid());
    EXPECT_EQ(b.get(), fds[0]);
    EXPECT_TRUE(is_open(fds[0]));
  }
  EXPECT_FALSE(is_open(fds[0]));
  UniqueFd c(fds[1]);
  const int raw = c.release();
  EXPECT_FALSE(c.valid());
  EXPECT_TRUE(is_open(raw));
  c.reset(raw);
  c.reset();
  EXPECT_FALSE(is_open(raw));
}

}  // namespace
}  // namespace contego::base
