// The seccomp_data.arch value of this build's own system calls: a filter or
// a supervisor that reads system call numbers must first check it (another
// architecture's calls, e.g. x32 or i386 ones on x86-64, number differently).
#pragma once

#include <cstdint>
#include <linux/audit.h>

namespace contego::intercept::seccomp {

#if defined(__x86_64__)
inline constexpr uint32_t kAuditArch = AUDIT_ARCH_X86_64;
#elif defined(__aarch64__)
inline constexpr uint32_t kAuditArch = AUDIT_ARCH_AARCH64;
#else
#error "unsupported architecture: name its AUDIT_ARCH here"
#endif

}  // namespace contego::intercept::seccomp
