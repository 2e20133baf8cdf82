#include "cli/carry_pairs.h"

#include <fmt/core.h>

#include "contego/core/image.h"

namespace contego::cli {
namespace {

template <typename Records, typename Same>
std::vector<uint16_t> pair_by_name(const Records& now, const Records& old, const char* kind,
                                   Same same, Pairing& p) {
  std::vector<uint16_t> ids(now.size(), core::kNone);
  for (size_t i = 0; i < now.size(); ++i) {
    for (size_t o = 0; o < old.size(); ++o) {
      if (old[o].name == now[i].name && same(now[i].record, old[o].record)) {
        ids[i] = static_cast<uint16_t>(o);
        ++p.paired;
        break;
      }
    }
    if (ids[i] == core::kNone) p.afresh.push_back(fmt::format("{} {}", kind, now[i].name));
  }
  return ids;
}

}  // namespace

Result<Pairing> pair_for_carry(const image::ImageModel& now, const image::ImageModel& old) {
  Pairing p;
  if (now.devices.size() != old.devices.size()) {
    return make_error(fmt::format(
        "the new policy has {} devices, the running one {}: a reload keeps the devices (a fresh "
        "start adds or removes one: a monitor restart, or `contego kmod load`)",
        now.devices.size(), old.devices.size()));
  }
  for (size_t d = 0; d < now.devices.size(); ++d) {
    const auto& a = now.devices[d];
    const auto& b = old.devices[d];
    if (a.name != b.name || a.record.bus != b.record.bus || a.record.addr != b.record.addr ||
        a.record.ten_bit != b.record.ten_bit || a.record.profile != b.record.profile) {
      return make_error(fmt::format(
          "device {} of the new policy (bus {}, address 0x{:02x}) is not the running policy's "
          "device {} (bus {}, address 0x{:02x}) with the same profile: a reload keeps the "
          "devices, in their order (a fresh start changes them: a monitor restart, or `contego "
          "kmod load`)",
          a.name, a.record.bus, a.record.addr, b.name, b.record.bus, b.record.addr));
    }
    p.devices.push_back(static_cast<uint16_t>(d));
  }
  for (size_t t = 0; t < now.tasks.size(); ++t) {
    const bool kept = t < old.tasks.size() && old.tasks[t].name == now.tasks[t].name;
    p.kept.push_back(kept);
    p.tasks.push_back(kept ? static_cast<uint16_t>(t) : core::kNone);
    if (!kept) p.afresh.push_back("task " + now.tasks[t].name);
  }
  auto task_pair = [&](uint16_t t) { return t < p.tasks.size() ? p.tasks[t] : core::kNone; };
  p.commands = pair_by_name(
      now.commands, old.commands, "command",
      [](const core::CommandRecord& a, const core::CommandRecord& b) {
        return a.device == b.device && a.field_count == b.field_count;
      },
      p);
  p.rates = pair_by_name(
      now.rates, old.rates, "rate limit",
      [&](const core::RateRecord& a, const core::RateRecord& b) {
        return a.device == b.device && task_pair(a.task) == b.task;
      },
      p);
  p.invariants = pair_by_name(
      now.invariants, old.invariants, "invariant",
      [](const core::InvariantRecord& a, const core::InvariantRecord& b) {
        return a.device == b.device && a.scope == b.scope;
      },
      p);
  return p;
}

}  // namespace contego::cli
