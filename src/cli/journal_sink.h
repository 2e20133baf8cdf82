// The monitor's entries for the systemd journal (monitor/journal_entry.h),
// sent with sd_journal_sendv: MESSAGE, PRIORITY, a MESSAGE_ID per kind
// (explained by the catalog, packaging/system/contego.catalog) and the
// CONTEGO_* fields, so that `journalctl -u contego-monitor -p warning` or
// `journalctl CONTEGO_VERDICT=failsafe` select what an operator looks for.
#ifndef CONTEGO_CLI_JOURNAL_SINK_H_
#define CONTEGO_CLI_JOURNAL_SINK_H_

#include <string>
#include <string_view>

#include "monitor/journal_entry.h"

namespace contego::cli {

// The MESSAGE_ID of an entry's kind (32 hex digits; one shared id for the
// kinds without their own).
std::string_view journal_message_id(std::string_view kind);

// A sink that stamps every entry with the enforced image's SHA-256. Without
// libsystemd, or when the journal refuses an entry, the message goes to
// standard error (the unit's stream reaches the journal too, unstructured).
monitor::JournalSink make_journal_sink(std::string image_sha256);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_JOURNAL_SINK_H_
