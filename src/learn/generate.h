// `contego policy generate`: a policy, and a test file, fitted to the traffic
// of audit logs recorded under an observe policy (devices, tasks and `allow`
// lines, run with --complain so nothing is dropped).
//
// What it writes, each line with a comment saying where it came from:
//  - the observe policy's constants, devices and signals as they were;
//  - per task: period and deadline from the release pattern measured in the
//    trace (the interval at which its most frequent command repeats), the
//    observe policy's wcet, priority and bindings, and `actuations` from the
//    most commands that acted in any window of one period;
//  - the access matrix observed (`allow T -> D`, `allow T reads D`);
//  - per task and device, a rate limit over the commands that acted (the most
//    in any window of one period, plus the margin), and `0 per job else
//    reject EPERM` for every command of the device the task never sent;
//  - per command, a range invariant over each field's observed values (plus
//    the margin, within the field's legal range) and the channels used;
//  - *suggested* invariants, commented out, where a sensor reading separated
//    the commands of one substitution group in the trace (with the evidence),
//    and the sequences seen: a human decides.
// What the trace cannot give (which of several observed commands is right for
// a reading) is said in `findings`.
#ifndef CONTEGO_LEARN_GENERATE_H_
#define CONTEGO_LEARN_GENERATE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "base/result.h"
#include "learn/audit_trace.h"

namespace contego::learn {

struct GenerateOptions {
  std::string observe_policy;     // the policy the logs were recorded under
  std::vector<std::string> logs;  // named in the header
  uint32_t margin_percent = 25;   // added to observed maxima and value ranges
  std::string test_file_name;     // the generated test file's name, for the header
};

struct Generated {
  std::string policy;
  std::string tests;  // a `contego test` file of cases taken from the trace
  std::vector<std::string> findings;
};

Result<Generated> generate_policy(const Trace& trace, const GenerateOptions& options);

}  // namespace contego::learn

#endif  // CONTEGO_LEARN_GENERATE_H_
