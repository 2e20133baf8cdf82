// The monitor's counters and gauges in Prometheus's text exposition format,
// written atomically to a file for node_exporter's textfile collector
// (`contego monitor --metrics-file`): no network listener in the trusted
// daemon. Made from the status JSON (Server::status_json()).
#ifndef CONTEGO_MONITOR_METRICS_H_
#define CONTEGO_MONITOR_METRICS_H_

#include <string>

#include "base/result.h"

namespace contego::monitor {

// The exposition text of a status (as `contego status --json` prints it).
std::string metrics_text(const std::string& status_json);

// A label value in the exposition format: backslash, quote and newline escaped.
std::string metrics_label(const std::string& v);
// A family's HELP and TYPE lines, appended to `out`.
void metrics_family(std::string& out, const char* name, const char* type, const char* help);

// Writes `text` to `path` atomically: a temporary file beside it, fsync'd,
// then renamed over it (a scrape never sees half a file). The error names
// the path and the reason.
Status write_metrics_file(const std::string& path, const std::string& text);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_METRICS_H_
