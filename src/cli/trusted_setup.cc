#include "cli/trusted_setup.h"

#include <fmt/core.h>

#include "bus/linux_i2cdev.h"
#include "policy/compile.h"

namespace contego::monitor {

Result<std::unique_ptr<Trusted>> setup(const SetupOptions& o) {
  auto t = std::make_unique<Trusted>();
  if (Status s = t->audit.open(o.audit); !s.ok()) return make_error(s.error());
  const policy::CompileOutput out = policy::compile_file(o.policy);
  if (!out.ok) {
    std::string msg = "policy " + o.policy + " does not compile:";
    for (const auto& d : out.diagnostics) msg += "\n" + d.rendered;
    return make_error(msg);
  }
  t->decider = std::make_unique<CoreDecider>();
  const core::LoadResult lr =
      t->decider->checker().load(out.image.data(), static_cast<uint32_t>(out.image.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(
        fmt::format("policy image of {} refused by the verifier: {} (section {}, record {})",
                    o.policy, core::load_status_name(lr.status), lr.section, lr.index));
  }
  std::vector<std::string> names;
  for (size_t i = 0; i < out.model.tasks.size(); ++i) {
    t->tasks[out.model.tasks[i].name] = static_cast<uint16_t>(i);
    names.push_back(out.model.tasks[i].name);
  }
  t->monitor = std::make_unique<Monitor>(*t->decider, t->audit);
  t->monitor->set_task_names(names);
  t->monitor->set_budget_factor(o.budget_factor);
  for (const auto& [n, path] : o.real_buses) {
    auto b = bus::LinuxI2cDev::open(path);
    if (!b.ok()) return make_error(b.error());
    t->monitor->add_bus(static_cast<uint8_t>(n), b->get());
    t->buses.push_back(std::move(*b));
  }
  for (int n : o.virtual_buses) {
    auto vb = std::make_unique<bus::VirtualBus>();
    vb->attach(std::make_shared<bus::Pca9685>(0x40));
    vb->attach(std::make_shared<bus::GoPiGo2>(0x08));
    vb->attach(std::make_shared<bus::LineFollower>(0x06));
    t->monitor->add_bus(static_cast<uint8_t>(n), vb.get());
    t->buses.push_back(std::move(vb));
  }
  t->audit.event("start", fmt::format("policy {}, {} tasks, worst-case cost {} instructions",
                                      o.policy, names.size(), out.worst_case_cost));
  t->monitor->sample_all();
  t->monitor->drive_safe_state("start");
  t->monitor->start_sampling();
  return t;
}

}  // namespace contego::monitor
