// The supervisor's side of the seccomp user-notification listener: the five
// things the call handler does with it (receive a call, ask whether it is
// still pending, answer it, let the kernel run it, install a descriptor into
// the caller). NotificationChannel is the seam: the handler's logic is unit
// tested against a fake (call_handler_test.cc) without a filter or a kernel
// facility; ListenerChannel is the real one, one ioctl per operation.
//
// Thread-safety: none; one thread receives and answers.
#ifndef CONTEGO_INTERCEPT_SECCOMP_NOTIFICATION_CHANNEL_H_
#define CONTEGO_INTERCEPT_SECCOMP_NOTIFICATION_CHANNEL_H_

#include <cstdint>
#include <linux/seccomp.h>
#include <vector>

namespace contego::intercept::seccomp {

class NotificationChannel {
 public:
  virtual ~NotificationChannel() = default;
  // Waits for the next notified call: 0, or the errno of the failure.
  virtual int receive(seccomp_notif& n) = 0;
  // Whether call `id` is still waiting for its answer (the caller may have
  // been killed or interrupted since it was received).
  virtual bool valid(uint64_t id) = 0;
  // Answers call `id` with `value` (err == 0) or fails it with errno `err`.
  virtual void reply(uint64_t id, int64_t value, int err) = 0;
  // Lets the kernel perform call `id` itself.
  virtual void continue_call(uint64_t id) = 0;
  // Installs this process's `own_fd` at number `slot` of the caller of `id`
  // (replacing what is there; close-on-exec if `cloexec`) and answers the
  // call with `slot`, in one step. >= 0 when done, else -1 (errno).
  virtual int add_fd(uint64_t id, int own_fd, int slot, bool cloexec) = 0;
};

// The listener descriptor itself (not owned).
class ListenerChannel final : public NotificationChannel {
 public:
  // Asks the kernel once how large a notification is (it may be larger than
  // this build's seccomp_notif).
  explicit ListenerChannel(int listener);
  int fd() const { return listener_; }
  // SECCOMP_USER_NOTIF_FD_SYNC_WAKE_UP: false when the kernel has no such flag.
  bool enable_sync_wakeup();

  int receive(seccomp_notif& n) override;
  bool valid(uint64_t id) override;
  void reply(uint64_t id, int64_t value, int err) override;
  void continue_call(uint64_t id) override;
  int add_fd(uint64_t id, int own_fd, int slot, bool cloexec) override;

 private:
  int listener_;
  std::vector<uint8_t> buffer_;  // one notification of the kernel's size
};

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_NOTIFICATION_CHANNEL_H_
