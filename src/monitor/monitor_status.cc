// Monitor::status_json(): the monitor's state for `contego status`, as JSON.
// A cold path (an operator's request): it takes the monitor's lock once.
#include <nlohmann/json.hpp>

#include "monitor/monitor.h"

namespace contego::monitor {

std::string Monitor::status_json() const {
  nlohmann::json tasks = nlohmann::json::array();
  nlohmann::json devices = nlohmann::json::array();
  base::MutexLock lock(mu_);
  const uint64_t now = clock_.now_us();
  for (size_t i = 0; i < names_.tasks.size(); ++i) {
    const auto task = static_cast<uint16_t>(i);
    const DecisionCounts c = drops_.counts(task);
    nlohmann::json t = {{"id", i},
                        {"name", names_.tasks[i]},
                        {"period_us", decider_->task_period_us(task)},
                        {"decisions",
                         {{"allowed", c.allowed},
                          {"staged", c.staged},
                          {"ignored", c.ignored},
                          {"substituted", c.substituted},
                          {"refused", c.refused},
                          {"complained", c.complained}}},
                        {"complain", complains_task_locked(task)}};
    const auto phase = job_phase_us_.find(task);
    const uint64_t period = decider_->task_period_us(task);
    // The job now on the task's grid: 0 before contact.
    t["job"] = phase == job_phase_us_.end() ? 0 : contego_grid_job(phase->second, period, now);
    if (auto b = budgets_.find(task); b != budgets_.end()) {
      const contego_job_budget& counts = b->second.counts;
      t["budget"] = {{"job", counts.job}, {"acted", counts.acted}, {"dropped", counts.dropped}};
    }
    tasks.push_back(std::move(t));
  }
  for (uint32_t d = 0; d < decider_->device_count(); ++d) {
    const auto id = static_cast<uint16_t>(d);
    nlohmann::json dev = {
        {"id", d},
        {"name", d < names_.devices.size() ? names_.devices[d] : std::to_string(d)},
        {"latched", decider_->latched(id)}};
    const core::DeviceRecord& rec = decider_->device(id);
    // A sensor's newest reading (the monitor's sample or a task's read);
    // none fresh enough: its signals are unavailable.
    if (const readings::Reading* r = readings_.for_check(core::kNoTask, id, now)) {
      dev["sample_age_ms"] = now >= r->taken_at_us ? (now - r->taken_at_us) / 1000 : 0;
    } else if (rec.sample_len != 0) {
      dev["sample_age_ms"] = nullptr;
    }
    // null: never driven since the start (an --allow-degraded start).
    if (auto s = safe_at_us_.find(id); s != safe_at_us_.end()) {
      dev["safe_state_age_s"] = now >= s->second ? (now - s->second) / 1000000 : 0;
    } else if ((rec.role & core::kRoleActuator) != 0 && rec.safe_count != 0) {
      dev["safe_state_age_s"] = nullptr;
    }
    devices.push_back(std::move(dev));
  }
  nlohmann::json cost = {{"bounds_ns", kCheckCostBoundsNs},
                         {"counts", check_cost_.counts},
                         {"sum_ns", check_cost_.sum_ns},
                         {"count", check_cost_.count}};
  const nlohmann::json out = {
      {"tasks", std::move(tasks)},     {"check_cost", std::move(cost)},
      {"devices", std::move(devices)}, {"decisions", decisions_.load()},
      {"holds", holds_.load()},        {"audit_refusals", audit_refusals_.load()},
      {"complain", complain_.any()},   {"budget_factor", budget_factor_.load()}};
  return out.dump();
}

}  // namespace contego::monitor
