// Audit logs read back as a trace: the decision records (what each task sent,
// decoded, with the readings and job it was judged with) and the events that
// change the checker's state (a task's exit ends its session), in log order.
// What `contego replay` re-decides and `contego policy generate` learns from.
//
// A trace is read only from logs whose hash chain holds (several files are
// one chain, oldest first, as `contego audit` takes them); a damaged,
// truncated or foreign line is refused with its file and line number.
#ifndef CONTEGO_LEARN_AUDIT_TRACE_H_
#define CONTEGO_LEARN_AUDIT_TRACE_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "base/result.h"

namespace contego::learn {

// A sensor's sample as a decision saw it (the record's `readings`).
struct SeenReading {
  bool present = false;  // false: no sample (the record says null)
  uint64_t age_us = 0;
  std::vector<uint8_t> bytes;
};

struct TraceDecision {
  std::string file;
  uint64_t line = 0;     // 1-based, in `file`
  uint64_t t_us = 0;     // when it was written (wall clock)
  int64_t tx = -1;       // the writer's check number (-1: not recorded)
  int64_t mono_us = -1;  // contego.ko's time of the decision (-1: not recorded)
  std::string task;      // the task's name
  uint32_t job = 0;
  uint8_t bus = 0;
  uint16_t addr = 0;
  bool read = false;  // a read or a probe (its reason is read-allowed or read-denied)
  std::vector<uint8_t> bytes;
  std::string device;   // the device's name ("" : none)
  std::string command;  // the command's name ("" : not decoded)
  std::vector<int64_t> fields;
  uint32_t index = 0;  // register-map channel
  std::string decision, reason, rule;
  std::string substitute;  // hex, as written
  bool complain = false;   // recorded in complain mode: it acted as sent
  bool has_readings = false;
  std::map<std::string, SeenReading> readings;  // by sensor device name
};

// Something between decisions that the checker's state follows.
struct TraceEvent {
  enum class Kind { kSessionEnd, kSafeState, kReset };
  Kind kind = Kind::kSafeState;
  size_t before = 0;  // index of the first decision after it
  std::string name;   // kSessionEnd: the task; kReset: the device
  uint64_t t_us = 0;
};

struct Trace {
  std::vector<TraceDecision> decisions;
  std::vector<TraceEvent> events;
  std::vector<std::string> policies;  // what each `start` record says the log ran
  uint64_t lines = 0;
};

// Reads `paths` (oldest first) as one chain. Decision records must carry the
// policy's names (task_name; device_name and command_name when decoded):
// numbers alone cannot be mapped to another policy and are refused.
Result<Trace> read_trace(const std::vector<std::string>& paths);

// Whether two records are of one checked transaction (a register-map write
// of several commands gives one record per command): the same `tx` of one
// file, or, in logs without it, the same task, address, bytes and time (the
// module's `mono_us` in contego.ko's logs).
bool same_transaction(const TraceDecision& a, const TraceDecision& b);

// "01 46 50" -> bytes; false on anything but hex pairs separated by spaces.
bool parse_hex_bytes(const std::string& text, std::vector<uint8_t>& out);

}  // namespace contego::learn

#endif  // CONTEGO_LEARN_AUDIT_TRACE_H_
