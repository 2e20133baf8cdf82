#include "monitor/journal_entry.h"

#include <utility>

namespace contego::monitor {

Priority event_priority(std::string_view kind) {
  static constexpr std::pair<std::string_view, Priority> kPriorities[] = {
      {"fault", Priority::kError},
      {"bus-error", Priority::kError},
      {"audit-gap", Priority::kError},
      {"accept-failed", Priority::kError},
      {"start-refused", Priority::kError},
      {"policy-load-refused", Priority::kError},
      {"safe-state", Priority::kWarning},
      {"adapter", Priority::kWarning},
      {"degraded-start", Priority::kWarning},
      {"over-budget", Priority::kWarning},
      {"session-refused", Priority::kWarning},
      {"hello-refused", Priority::kWarning},
      {"identity-refused", Priority::kWarning},
      {"reset-refused", Priority::kWarning},
      {"reload-refused", Priority::kWarning},
      {"malformed", Priority::kWarning},
      {"inexpressible", Priority::kWarning},
      {"staged-dropped", Priority::kWarning},
      {"realtime-refused", Priority::kWarning},
      {"suppressed", Priority::kWarning},
      {"start", Priority::kNotice},
      {"stop", Priority::kNotice},
      {"reset", Priority::kNotice},
      {"reload", Priority::kNotice},
      {"checkpoint", Priority::kNotice},
      {"policy-load", Priority::kNotice},
  };
  for (const auto& [name, priority] : kPriorities) {
    if (name == kind) return priority;
  }
  return Priority::kInfo;  // signal, shadow, peer, unused-bus, ...
}

}  // namespace contego::monitor
