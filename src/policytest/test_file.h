// Policy unit-test files (`*.test`): what `contego test POLICY TESTFILE` runs.
// docs/policy-testing.md describes the format; in short:
//
//   task follower                       # defaults for every case
//   test "forward on the line" {
//     sensor line raw = [800, 900, 1015, 850, 800]
//     job 1
//     send gopigo.set_left_speed(80)             -> allow
//     write i2c-1 0x08 [01 6E 00 00 00]         -> failsafe fwd() rule INV3
//   }
//
// parse_test_file() reports every error it finds as `file:line:col: message`
// and recovers at the next line.
//
// Host code: allocates, never linked into the trusted core.
#ifndef CONTEGO_POLICYTEST_TEST_FILE_H_
#define CONTEGO_POLICYTEST_TEST_FILE_H_

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "contego/core/host.h"
#include "contego/core/transaction.h"
#include "contego/core/verdict.h"

namespace contego::policytest {

struct Loc {
  uint32_t line = 0;    // 1-based
  uint32_t column = 0;  // 1-based
};

// `name=value` or a positional `value` (name empty).
struct Arg {
  std::string name;
  int64_t value = 0;
};

// `gopigo.set_left_speed(85)`, `arm.led(5, off=420)`; in an expectation the
// device may be left out: `set_left_speed(speed=80)`.
struct Call {
  std::string device;
  std::string command;
  std::vector<Arg> args;
  Loc loc;
};

struct Expect {
  core::Decision decision = core::Decision::kAllow;
  std::optional<int> reply_errno;     // reject ERRNO
  std::vector<Call> substitutes;      // failsafe CMD, CMD...: what reached the bus
  std::optional<std::string> reason;  // reason NAME (as core::reason_name)
  std::optional<std::string> rule;    // rule NAME (invariant / rate name, access, latch)
  std::string text;                   // the expectation as written, for the report
  Loc loc;
};

// One bus transaction, either raw or a command encoded with the device's profile.
struct Step {
  std::optional<Call> call;  // send DEV.CMD(...)
  core::TxKind kind = core::TxKind::kWrite;
  uint8_t bus = 0;
  uint16_t addr = 0;
  std::vector<uint8_t> bytes;  // write: bytes after the address; read: register pointer bytes
  std::string text;            // the step as written
  Expect expect;
  Loc loc;
};

struct SetTask {
  std::string task;  // "none" = a client that is no declared task
  Loc loc;
};
struct SetJob {
  uint32_t job = 0;
  Loc loc;
};
struct SetTime {
  uint64_t us = 0;
  bool relative = false;  // `after 10ms` advances, `at 200ms` sets
  Loc loc;
};
// `sensor line raw = [..]`, `sensor tank level=900 temp=-5`,
// `sensor line sample [02 ff ...]`, `sensor line none`.
struct SetSensor {
  std::string device;
  bool none = false;
  std::optional<std::vector<uint8_t>> sample;  // raw bytes
  // name -> values; a list assigns NAME0, NAME1, ... (`raw = [..]` sets raw0..raw4)
  std::vector<std::pair<std::string, std::vector<int64_t>>> fields;
  std::vector<bool> is_list;  // per entry of `fields`
  Loc loc;
};

using Action = std::variant<SetTask, SetJob, SetTime, SetSensor, Step>;

struct TestCase {
  std::string name;
  std::vector<Action> actions;
  Loc loc;
};

struct TestFile {
  std::string file_name;
  std::vector<Action> defaults;  // statements before the first case, applied to every case
  std::vector<TestCase> cases;
};

struct ParseError {
  Loc loc;
  std::string message;
  std::string rendered;  // file:line:col: error: message
};

struct ParseResult {
  TestFile file;
  std::vector<ParseError> errors;  // all of them, in source order
  bool ok() const { return errors.empty(); }
};

ParseResult parse_test_file(const std::string& file_name, const std::string& text);

// errno names accepted after `reject` (EPERM, EACCES, EBADF, EIO, EINVAL, EBUSY, EAGAIN).
std::optional<int> errno_from_name(const std::string& name);

}  // namespace contego::policytest

#endif  // CONTEGO_POLICYTEST_TEST_FILE_H_
