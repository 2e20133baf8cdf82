// Seccomp user-notification constants newer than some distributions'
// kernel headers (Linux 5.19, 6.6); header-only, so that tools which link nothing
// of contego (bench/kernel_floor.cc) can share it.
#ifndef CONTEGO_INTERCEPT_SECCOMP_UAPI_FALLBACK_H_
#define CONTEGO_INTERCEPT_SECCOMP_UAPI_FALLBACK_H_

#include <linux/seccomp.h>

#ifndef SECCOMP_IOCTL_NOTIF_SET_FLAGS
#define SECCOMP_IOCTL_NOTIF_SET_FLAGS SECCOMP_IOW(4, __u64)
#endif
#ifndef SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP
#define SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP (1UL << 0)
#endif

#ifndef SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV
#define SECCOMP_FILTER_FLAG_WAIT_KILLABLE_RECV (1UL << 5)
#endif

#endif  // CONTEGO_INTERCEPT_SECCOMP_UAPI_FALLBACK_H_
