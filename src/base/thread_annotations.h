// Clang's thread-safety analysis (-Wthread-safety): which lock guards which
// field, and which functions must be called with it held, said so that the
// compiler checks it. Under GCC (the build's compiler) every macro expands to
// nothing; the `tree` test thread_safety.clang runs the analysis
// (docs/development.md, "Contracts the compiler checks"). The names are
// those of Clang's documentation (ThreadSafetyAnalysis.html).
#ifndef CONTEGO_BASE_THREAD_ANNOTATIONS_H_
#define CONTEGO_BASE_THREAD_ANNOTATIONS_H_

#if defined(__clang__)
#define CONTEGO_THREAD_ANNOTATION_(x) __attribute__((x))
#else
#define CONTEGO_THREAD_ANNOTATION_(x)
#endif

// A type that is a lock (the analysis calls it a capability).
#define CAPABILITY(x) CONTEGO_THREAD_ANNOTATION_(capability(x))
// An RAII type that holds a lock for its lifetime.
#define SCOPED_CAPABILITY CONTEGO_THREAD_ANNOTATION_(scoped_lockable)
// A field read and written only with the lock held.
#define GUARDED_BY(x) CONTEGO_THREAD_ANNOTATION_(guarded_by(x))
// A pointer whose pointee is read and written only with the lock held.
#define PT_GUARDED_BY(x) CONTEGO_THREAD_ANNOTATION_(pt_guarded_by(x))
// Lock order: this lock is taken before / after the ones named.
#define ACQUIRED_BEFORE(...) CONTEGO_THREAD_ANNOTATION_(acquired_before(__VA_ARGS__))
#define ACQUIRED_AFTER(...) CONTEGO_THREAD_ANNOTATION_(acquired_after(__VA_ARGS__))
// The caller holds the lock(s) (and still does on return).
#define REQUIRES(...) CONTEGO_THREAD_ANNOTATION_(requires_capability(__VA_ARGS__))
// The function takes / gives back the lock(s).
#define ACQUIRE(...) CONTEGO_THREAD_ANNOTATION_(acquire_capability(__VA_ARGS__))
#define RELEASE(...) CONTEGO_THREAD_ANNOTATION_(release_capability(__VA_ARGS__))
#define TRY_ACQUIRE(...) CONTEGO_THREAD_ANNOTATION_(try_acquire_capability(__VA_ARGS__))
// The caller must not hold the lock(s): the function takes them itself.
#define EXCLUDES(...) CONTEGO_THREAD_ANNOTATION_(locks_excluded(__VA_ARGS__))
// The function checks (or knows) that the lock is held; the analysis
// takes it as held from there on.
#define ASSERT_CAPABILITY(x) CONTEGO_THREAD_ANNOTATION_(assert_capability(x))
// The function returns a reference to the lock `x`.
#define RETURN_CAPABILITY(x) CONTEGO_THREAD_ANNOTATION_(lock_returned(x))
// The analysis skips this function; say why beside it.
#define NO_THREAD_SAFETY_ANALYSIS CONTEGO_THREAD_ANNOTATION_(no_thread_safety_analysis)

#endif  // CONTEGO_BASE_THREAD_ANNOTATIONS_H_
