// std::mutex with the annotations of base/thread_annotations.h, and its
// scoped lock (the one way the trusted daemon takes a lock), whose waits on a
// std::condition_variable keep the lock held as far as the analysis sees:
// a wait gives the mutex up and takes it back before it returns, as
// std::condition_variable::wait does. Header only; the code is std::mutex's
// and std::unique_lock's.
//
// Thread-safety: a Mutex is what makes other things thread-safe; a MutexLock
// belongs to the thread that made it.
#ifndef CONTEGO_BASE_MUTEX_H_
#define CONTEGO_BASE_MUTEX_H_

#include <chrono>
#include <condition_variable>
#include <mutex>

#include "base/thread_annotations.h"

namespace contego::base {

class CAPABILITY("mutex") Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void lock() ACQUIRE() { mu_.lock(); }
  void unlock() RELEASE() { mu_.unlock(); }
  bool try_lock() TRY_ACQUIRE(true) { return mu_.try_lock(); }
  // Tells the analysis that the calling thread holds the mutex, where it
  // cannot see it: a callback that the code holding the lock calls through
  // a function pointer. Checks nothing at run time (std::mutex cannot say
  // who holds it); the caller's comment says why it is true.
  void assume_held() const ASSERT_CAPABILITY(this) {}

 private:
  friend class MutexLock;
  std::mutex mu_;
};

class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex& mu) ACQUIRE(mu) : lock_(mu.mu_) {}
  ~MutexLock() RELEASE() {}
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // Gives the mutex back before the scope ends (the destructor then does
  // nothing), and takes it again.
  void unlock() RELEASE() { lock_.unlock(); }
  void lock() ACQUIRE() { lock_.lock(); }

  // std::condition_variable's waits, on this lock's mutex.
  void wait(std::condition_variable& cv) { cv.wait(lock_); }
  template <typename Predicate>
  void wait(std::condition_variable& cv, Predicate stop_waiting) {
    cv.wait(lock_, stop_waiting);
  }
  template <typename Rep, typename Period>
  std::cv_status wait_for(std::condition_variable& cv,
                          const std::chrono::duration<Rep, Period>& timeout) {
    return cv.wait_for(lock_, timeout);
  }
  template <typename Rep, typename Period, typename Predicate>
  bool wait_for(std::condition_variable& cv, const std::chrono::duration<Rep, Period>& timeout,
                Predicate stop_waiting) {
    return cv.wait_for(lock_, timeout, stop_waiting);
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace contego::base

#endif  // CONTEGO_BASE_MUTEX_H_
