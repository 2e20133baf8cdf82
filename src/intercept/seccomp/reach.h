// What keeps the supervisor out of the supervised program's reach and makes
// the program the supervisor names the one that runs (issue 11, part 2).
#ifndef CONTEGO_INTERCEPT_SECCOMP_REACH_H_
#define CONTEGO_INTERCEPT_SECCOMP_REACH_H_

#include <string>

namespace contego::intercept::seccomp {

// The absolute path execvp would execute for `name` ("" if none): what the
// child executes and what a supervisor names to the monitor.
std::string resolve_program(const std::string& name);

// The supervisor is not dumpable while any run() has a program that may run
// (concurrent run()s share the process): the first enter sets it, the last
// leave restores what it was.
void enter_undumpable();
void leave_undumpable();

}  // namespace contego::intercept::seccomp

#endif  // CONTEGO_INTERCEPT_SECCOMP_REACH_H_
