// One line in words per audit-log record (`contego audit --explain`): who
// sent what to which device, what the monitor decided, which rule decided it
// and why. Reads the names the monitor writes beside the numbers; a log
// written before names were recorded gets the numbers instead.
#ifndef CONTEGO_MONITOR_AUDIT_EXPLAIN_H_
#define CONTEGO_MONITOR_AUDIT_EXPLAIN_H_

#include <string>

namespace contego::monitor {

// `line` is one line of the log. Returns the explanation, or an empty
// string for a line that is not a JSON object (padding, a cut-off tail).
std::string explain_audit_line(const std::string& line);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_AUDIT_EXPLAIN_H_
