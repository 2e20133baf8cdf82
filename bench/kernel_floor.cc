// contego-kernel-floor: what the kernel and the machine charge for the
// primitives the enclave clients are built from, measured the same way as
// `contego bench` (CLOCK_MONOTONIC around each operation, N trials, median,
// p99, worst). The figures are the floor under each path: no client can
// check a command through seccomp faster than one notification round trip,
// nor cross to another process faster than the wake-up it needs.
//
//   contego-kernel-floor [TRIALS]      (default 10000)
#include <fcntl.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <linux/filter.h>
#include <linux/futex.h>
#include <linux/seccomp.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <vector>

#include "intercept/seccomp/uapi_fallback.h"

namespace {

uint64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<uint64_t>(t.tv_sec) * 1000000000u + static_cast<uint64_t>(t.tv_nsec);
}

void report(const char* what, std::vector<uint64_t> ns) {
  if (ns.empty()) {
    printf("%-44s not measured\n", what);
    return;
  }
  std::sort(ns.begin(), ns.end());
  const auto at = [&](double q) {
    return static_cast<double>(ns[std::min(
               ns.size() - 1, static_cast<size_t>(q * static_cast<double>(ns.size())))]) /
           1000.0;
  };
  printf("%-44s %9.2f %9.2f %10.1f\n", what, at(0.5), at(0.99),
         static_cast<double>(ns.back()) / 1000.0);
}

// One byte and room for one passed descriptor.
struct FdMessage {
  char data = 0;
  iovec io{&data, 1};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
  msghdr m{};
  FdMessage() {
    m.msg_iov = &io;
    m.msg_iovlen = 1;
    m.msg_control = control;
    m.msg_controllen = sizeof control;
  }
  FdMessage(const FdMessage&) = delete;
  FdMessage& operator=(const FdMessage&) = delete;
};

// Passes a descriptor over a Unix socket.
void send_fd(int sock, int fd) {
  FdMessage msg;
  msghdr& m = msg.m;
  cmsghdr* h = CMSG_FIRSTHDR(&m);
  h->cmsg_level = SOL_SOCKET;
  h->cmsg_type = SCM_RIGHTS;
  h->cmsg_len = CMSG_LEN(sizeof(int));
  memcpy(CMSG_DATA(h), &fd, sizeof fd);
  (void)!sendmsg(sock, &m, 0);
}

int recv_fd(int sock) {
  FdMessage msg;
  msghdr& m = msg.m;
  if (recvmsg(sock, &m, 0) != 1 || CMSG_FIRSTHDR(&m) == nullptr) return -1;
  int fd = -1;
  memcpy(&fd, CMSG_DATA(CMSG_FIRSTHDR(&m)), sizeof fd);
  return fd;
}

// One trapped getppid() answered by a supervisor in this process: the
// child times its calls and writes the samples into shared memory.
std::vector<uint64_t> seccomp_round_trip(size_t trials, bool sync_wakeup) {
  auto* samples =
      static_cast<uint64_t*>(mmap(nullptr, trials * sizeof(uint64_t), PROT_READ | PROT_WRITE,
                                  MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  int sv[2];
  if (samples == MAP_FAILED || socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) return {};
  const pid_t child = fork();
  if (child == 0) {
    sock_filter f[] = {
        BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, nr)),
        BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, SYS_getppid, 0, 1),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_USER_NOTIF),
        BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
    };
    sock_fprog prog{4, f};
    prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0);
    const int fd = static_cast<int>(
        syscall(SYS_seccomp, SECCOMP_SET_MODE_FILTER, SECCOMP_FILTER_FLAG_NEW_LISTENER, &prog));
    if (fd < 0) _exit(1);
    send_fd(sv[1], fd);
    close(fd);
    char go;
    if (read(sv[1], &go, 1) != 1) _exit(1);
    for (size_t i = 0; i < trials; ++i) {
      const uint64_t t0 = now_ns();
      syscall(SYS_getppid);
      samples[i] = now_ns() - t0;
    }
    _exit(0);
  }
  const int listener = recv_fd(sv[0]);
  std::vector<uint64_t> out;
  if (listener >= 0) {
    if (sync_wakeup) {
      ioctl(listener, SECCOMP_IOCTL_NOTIF_SET_FLAGS, SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP);
    }
    (void)!write(sv[0], "g", 1);
    for (size_t answered = 0; answered < trials; ++answered) {
      seccomp_notif n{};
      if (ioctl(listener, SECCOMP_IOCTL_NOTIF_RECV, &n) != 0) break;
      seccomp_notif_resp r{};
      r.id = n.id;
      r.val = 1;
      ioctl(listener, SECCOMP_IOCTL_NOTIF_SEND, &r);
    }
    close(listener);
  }
  int status = 0;
  waitpid(child, &status, 0);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) out.assign(samples, samples + trials);
  close(sv[0]);
  close(sv[1]);
  munmap(samples, trials * sizeof(uint64_t));
  return out;
}

// A request/answer between two processes through two words of shared
// memory, either busy-waiting or sleeping on a futex.
std::vector<uint64_t> ping_pong(size_t trials, bool futex) {
  auto* words = static_cast<std::atomic<uint32_t>*>(
      mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  if (words == MAP_FAILED) return {};
  std::atomic<uint32_t>& request = words[0];
  std::atomic<uint32_t>& answer = words[16];  // another cache line
  request.store(0);
  answer.store(0);
  const auto wait_for = [futex](std::atomic<uint32_t>& w, uint32_t v) {
    while (w.load(std::memory_order_acquire) != v) {
      if (futex) {
        syscall(SYS_futex, reinterpret_cast<uint32_t*>(&w), FUTEX_WAIT, v - 1, nullptr, nullptr, 0);
      }
    }
  };
  const auto post = [futex](std::atomic<uint32_t>& w, uint32_t v) {
    w.store(v, std::memory_order_release);
    if (futex)
      syscall(SYS_futex, reinterpret_cast<uint32_t*>(&w), FUTEX_WAKE, 1, nullptr, nullptr, 0);
  };
  const pid_t child = fork();
  if (child == 0) {
    for (uint32_t i = 1; i <= trials; ++i) {
      wait_for(request, i);
      post(answer, i);
    }
    _exit(0);
  }
  std::vector<uint64_t> ns(trials);
  for (uint32_t i = 1; i <= trials; ++i) {
    const uint64_t t0 = now_ns();
    post(request, i);
    wait_for(answer, i);
    ns[i - 1] = now_ns() - t0;
  }
  waitpid(child, nullptr, 0);
  munmap(words, 4096);
  return ns;
}

}  // namespace

int main(int argc, char** argv) {
  const long parsed = argc > 1 ? strtol(argv[1], nullptr, 10) : 10000;
  if (parsed <= 0 || parsed > 10000000) {
    fprintf(stderr, "usage: %s [TRIALS]\n", argv[0]);
    return 2;
  }
  const auto trials = static_cast<size_t>(parsed);
  printf("contego-kernel-floor: %zu trials each, CLOCK_MONOTONIC\n", trials);
  printf("%-44s %9s %9s %10s\n", "", "median µs", "p99 µs", "worst µs");

  std::vector<uint64_t> ns(trials);
  for (auto& v : ns) {
    const uint64_t t0 = now_ns();
    syscall(SYS_getppid);
    v = now_ns() - t0;
  }
  report("bare system call (getppid)", ns);

  char src[8] = "command", dst[8];
  for (auto& v : ns) {
    iovec local{dst, sizeof dst}, remote{src, sizeof src};
    const uint64_t t0 = now_ns();
    process_vm_readv(getpid(), &local, 1, &remote, 1, 0);
    v = now_ns() - t0;
  }
  report("process_vm_readv, 8 bytes", ns);

  report("seccomp user notification round trip", seccomp_round_trip(trials, false));
  report("  the same with SYNC_WAKE_UP", seccomp_round_trip(trials, true));
  report("futex round trip to another process", ping_pong(trials, true));
  report("shared-memory round trip, both spinning", ping_pong(trials, false));
  return 0;
}
