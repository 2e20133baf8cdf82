// Monitor::reload: the policy replaced between two transfers, the sessions,
// the buses and the model kept (`contego reload`, docs/deployment.md).
#include <fmt/core.h>

#include "monitor/expressible.h"
#include "monitor/monitor.h"

namespace contego::monitor {

Result<std::string> Monitor::reload(Decider& decider, Policy policy,
                                    const std::function<Result<std::string>()>& carry) {
  base::MutexLock lock(mu_);
  if (decider.device_count() != decider_->device_count()) {
    return make_error(
        fmt::format("the new policy has {} devices, the running one {}: a reload "
                    "keeps the devices",
                    decider.device_count(), decider_->device_count()));
  }
  // A reload drives no safe state: each must at least have a form on its
  // adapter, or a fail-safe under the new policy would act nothing. (A bus
  // the monitor lacks is no new gap: the running policy has the device too.)
  for (uint16_t d = 0; d < decider.device_count(); ++d) {
    core::Verdict v{};
    if ((decider.device(d).role & core::kRoleActuator) == 0 || !decider.preview_safe_state(d, &v))
      continue;
    const auto bus = buses_.find(v.bus);
    if (bus == buses_.end()) continue;
    if (Status form = emits_inexpressible(*bus->second, v, decider.device(d).ten_bit); !form.ok()) {
      return make_error(
          fmt::format("the safe state of {} (i2c-{} 0x{:02x}) has no form on its "
                      "adapter: {}",
                      d < policy.names.devices.size() ? policy.names.devices[d] : "?", v.bus,
                      v.addr, form.error()));
    }
  }
  Result<std::string> detail = carry();
  if (!detail.ok()) return detail;
  // No policy change without its record, and none of its decisions before it.
  if (!audit_.event("reload", *detail)) {
    return make_error(
        "the audit record of the reload could not be written; the running policy "
        "stays");
  }
  core::Host host{};
  host.context = this;
  host.read_sample = &Monitor::host_read_sample;
  host.audit = &Monitor::host_audit;
  decider.set_host(host);
  decider_ = &decider;
  for (uint16_t d = 0; d < decider_->device_count(); ++d) {
    readings_.redescribe(d, decider_->device(d));
  }
  // A task id that names another task now (or none) starts afresh.
  const size_t tasks = std::max(policy.kept.size(), names_.tasks.size());
  for (size_t t = 0; t < tasks; ++t) {
    if (t < policy.kept.size() && policy.kept[t]) continue;
    const auto id = static_cast<uint16_t>(t);
    job_phase_us_.erase(id);
    budgets_.erase(id);
    readings_.forget_task(id);
    drops_.forget(id);
  }
  names_ = std::move(policy.names);
  task_devices_ = std::move(policy.task_devices);
  complain_ = std::move(policy.complain);
  facts_ = std::move(policy.facts);
  return detail;
}

}  // namespace contego::monitor
