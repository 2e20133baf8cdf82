// `contego replay`: every recorded decision re-decided by another policy, in
// log order, with the readings and jobs of the log, and what would change.
//
// The trace is mapped to the policy by name (tasks, and the sensors whose
// readings a record carries); the bytes are decoded again by the policy's own
// device profiles. Each recorded transaction is one transfer of the checker;
// a task's exit ends its session and a reset clears a latch, as they did when
// the log was written.
#ifndef CONTEGO_LEARN_REPLAY_H_
#define CONTEGO_LEARN_REPLAY_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "base/result.h"
#include "image/image_model.h"
#include "learn/audit_trace.h"

namespace contego::learn {

// One verdict as recorded or as replayed.
struct Verdict {
  std::string decision;    // allow, ignore, failsafe, reject ("" : none)
  std::string reason;      // reason name
  std::string rule;        // rule name ("" : no rule)
  std::string command;     // the command's name as decoded
  std::string substitute;  // fail-safe bytes, hex
};

struct Change {
  const TraceDecision* record = nullptr;
  Verdict replayed;
};

struct ReplayReport {
  uint64_t decisions = 0;  // recorded decisions re-decided
  std::vector<Change> changes;
  // Per task: which job numbers were used ("the log's jobs", or "recomputed
  // on the policy's N ms period": the log's grid was another period).
  std::map<std::string, std::string> jobs;
  std::vector<std::string> notes;  // what could not be mapped, and why
};

// Replays `trace` against the verified `image` (with its `model`'s names).
Result<ReplayReport> replay(const Trace& trace, const image::ImageModel& model,
                            const std::vector<uint8_t>& image);

// The report as text: a summary line, then a table of the changes grouped by
// task, command, recorded and replayed verdict, with their first lines.
std::string format_replay(const ReplayReport& report, const std::string& policy_name);

// "ignore by START_SPEED (invariant-violated)".
std::string verdict_text(const Verdict& v);

}  // namespace contego::learn

#endif  // CONTEGO_LEARN_REPLAY_H_
