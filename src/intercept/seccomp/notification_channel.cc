#include "intercept/seccomp/notification_channel.h"

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <sys/ioctl.h>
#include <sys/syscall.h>

#include "intercept/seccomp/uapi_fallback.h"

namespace contego::intercept::seccomp {

ListenerChannel::ListenerChannel(int listener) : listener_(listener) {
  seccomp_notif_sizes sizes{};
  syscall(SYS_seccomp, SECCOMP_GET_NOTIF_SIZES, 0, &sizes);
  buffer_.resize(std::max<size_t>(sizes.seccomp_notif, sizeof(seccomp_notif)));
}

bool ListenerChannel::enable_sync_wakeup() {
  return ioctl(listener_, SECCOMP_IOCTL_NOTIF_SET_FLAGS, SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP) == 0;
}

int ListenerChannel::receive(seccomp_notif& n) {
  std::memset(buffer_.data(), 0, buffer_.size());  // RECV wants a zeroed buffer
  if (ioctl(listener_, SECCOMP_IOCTL_NOTIF_RECV, buffer_.data()) != 0) return errno;
  std::memcpy(&n, buffer_.data(), sizeof n);
  return 0;
}

bool ListenerChannel::valid(uint64_t id) {
  return ioctl(listener_, SECCOMP_IOCTL_NOTIF_ID_VALID, &id) == 0;
}

void ListenerChannel::reply(uint64_t id, int64_t value, int err) {
  seccomp_notif_resp r{};
  r.id = id;
  r.val = err == 0 ? value : 0;
  r.error = err == 0 ? 0 : -err;
  ioctl(listener_, SECCOMP_IOCTL_NOTIF_SEND, &r);  // ENOENT: the caller is gone or interrupted
}

void ListenerChannel::continue_call(uint64_t id) {
  seccomp_notif_resp r{};
  r.id = id;
  r.flags = SECCOMP_USER_NOTIF_FLAG_CONTINUE;
  ioctl(listener_, SECCOMP_IOCTL_NOTIF_SEND, &r);
}

int ListenerChannel::add_fd(uint64_t id, int own_fd, int slot, bool cloexec) {
  seccomp_notif_addfd a{};
  a.id = id;
  // SETFD: at exactly `slot`; SEND: the install is the answer, so the
  // caller never sees the number before the descriptor is there.
  a.flags = SECCOMP_ADDFD_FLAG_SETFD | SECCOMP_ADDFD_FLAG_SEND;
  a.srcfd = static_cast<uint32_t>(own_fd);
  a.newfd = static_cast<uint32_t>(slot);
  a.newfd_flags = cloexec ? O_CLOEXEC : 0;
  return ioctl(listener_, SECCOMP_IOCTL_NOTIF_ADDFD, &a);
}

}  // namespace contego::intercept::seccomp
