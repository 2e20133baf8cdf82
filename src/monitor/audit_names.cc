// The names a decision record carries beside its numbers (NameTable::of).
#include "monitor/audit_log.h"

namespace contego::monitor {

RecordNames NameTable::of(const core::AuditRecord& r) const {
  auto at = [](const std::vector<std::string>& v, uint16_t id) -> const char* {
    return id < v.size() ? v[id].c_str() : nullptr;
  };
  RecordNames n;
  n.task = at(tasks, r.task);
  n.device = at(devices, r.device);
  n.command = at(commands, r.command);
  switch (r.rule_kind) {
    case core::RuleKind::kRate:
      n.rule = at(rates, r.rule);
      break;
    case core::RuleKind::kInvariant:
      n.rule = at(invariants, r.rule);
      break;
    case core::RuleKind::kAccess:
      n.rule = "access";
      break;
    case core::RuleKind::kLatch:
      n.rule = "latch";
      break;
    case core::RuleKind::kNoRule:
      break;
  }
  return n;
}

}  // namespace contego::monitor
