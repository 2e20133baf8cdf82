#include "cli/policy_reload.h"

#include <errno.h>

#include <algorithm>
#include <fmt/core.h>
#include <fmt/format.h>
#include <memory>
#include <mutex>

#include "contego/core/image.h"

#include "bundle/bundle.h"
#include "bundle/minisign.h"
#include "cli/carry_pairs.h"

namespace contego::cli {
namespace {

using monitor::Server;

class Reloader {
 public:
  Reloader(const monitor::SetupOptions& options, monitor::Trusted& trusted, Server& server,
           std::function<void(const std::string&)> reloaded)
      : options_(options), trusted_(trusted), server_(server), reloaded_(std::move(reloaded)) {}

  Server::ReloadAnswer operator()(const gate::wire::ReloadRequest& request, uid_t uid) {
    std::lock_guard lock(mu_);  // one reload at a time
    return reload(request, uid);
  }

 private:
  static Server::ReloadAnswer refuse(int err, std::string why) { return {err, std::move(why)}; }

  // "" when unsigned and none is required; else who signed it.
  Result<std::string> signer(const gate::wire::ReloadRequest& r) const {
    if (r.signature.empty()) {
      if (!options_.require_signed) return std::string();
      return make_error(
          "--require-signed: the bundle has no signature (sign it with `minisign -Sm FILE`; "
          "`contego reload --bundle FILE` sends FILE.minisig)");
    }
    auto keys = bundle::load_trusted_keys(options_.keys_dir);
    if (!keys.ok()) return make_error("the bundle is signed, but " + keys.error());
    auto v = bundle::verify_minisign(r.bundle, r.signature, "the reload's signature", *keys);
    if (!v.ok()) return make_error(v.error());
    return fmt::format("signed by key ID {} ({}), trusted comment \"{}\"", v->key_id_hex,
                       v->key_source, v->trusted_comment);
  }

  Server::ReloadAnswer reload(const gate::wire::ReloadRequest& request, uid_t uid) {
    auto signed_by = signer(request);
    if (!signed_by.ok()) return refuse(EPERM, signed_by.error());
    auto b = bundle::decode_bundle(request.bundle, "the reload's bundle");
    if (!b.ok()) return refuse(EINVAL, b.error());
    // The host side stays what the monitor started with (its buses are open).
    if (b->budget_factor && *b->budget_factor != trusted_.budget_factor) {
      return refuse(EINVAL, fmt::format("the bundle's budget factor is {}, the running monitor's "
                                        "{}: a reload keeps it (a restart changes it)",
                                        *b->budget_factor, trusted_.budget_factor));
    }
    for (const auto& [n, path] : b->buses) {
      const auto running = trusted_.real_buses.find(n);
      if (running == trusted_.real_buses.end() || running->second != path) {
        return refuse(EINVAL, fmt::format("the bundle says bus {} is {}, the running monitor "
                                          "uses {}: a reload keeps the buses (a restart changes "
                                          "them)",
                                          n, path,
                                          running == trusted_.real_buses.end() ? "another adapter"
                                                                               : running->second));
      }
    }
    const std::string hash = bundle::image_sha256(b->image);
    auto model = image::deserialize(b->image);
    if (!model.ok()) return refuse(EINVAL, "the reload's image: " + model.error());
    auto next = std::make_unique<monitor::CoreDecider>();
    const core::LoadResult lr =
        next->checker().load(b->image.data(), static_cast<uint32_t>(b->image.size()));
    if (lr.status != core::LoadStatus::kOk) {
      return refuse(EINVAL, fmt::format("the reload's image is refused by the verifier: {} "
                                        "(section {}, record {})",
                                        core::load_status_name(lr.status), lr.section, lr.index));
    }
    auto pairing = pair_for_carry(*model, trusted_.model);
    if (!pairing.ok()) return refuse(EINVAL, pairing.error());
    const std::string source =
        fmt::format("{} (bundle reloaded by uid {}, SHA-256 {}{}{})", b->policy, uid, hash,
                    signed_by->empty() ? "" : ", ", *signed_by);
    std::map<std::string, uint16_t> tasks;
    for (size_t i = 0; i < model->tasks.size(); ++i) {
      tasks[model->tasks[i].name] = static_cast<uint16_t>(i);
    }
    auto host = monitor::host_tasks(b->tasks, tasks);
    if (!host.ok()) return refuse(EINVAL, host.error());
    std::map<std::string, monitor::TaskBinding>& bindings = host->bindings;
    const std::vector<std::string>& warnings = host->warnings;
    monitor::Monitor::Policy policy;
    policy.facts = std::move(host->facts);
    auto complain = monitor::complain_scope(options_, *model);
    if (!complain.ok()) return refuse(EINVAL, complain.error());
    policy.names = monitor::name_table(*model);
    for (const auto& a : model->access) policy.task_devices.push_back(a.actuate_devices);
    policy.complain = complain->first;
    policy.kept = pairing->kept;

    const std::string old_hash = trusted_.image_sha256;
    const Pairing& p = *pairing;
    auto carry = [&]() -> Result<std::string> {
      const core::Checker::CarryMap map{p.tasks.data(), p.devices.data(), p.commands.data(),
                                        p.rates.data(), p.invariants.data()};
      const core::Checker::CarryResult r =
          next->checker().carry_from(trusted_.decider->checker(), map);
      if (!r.ok) return make_error("the core refused to carry the running model over");
      // The journal names the new image from the reload's own entry on.
      if (reloaded_) reloaded_(hash);
      std::string detail = fmt::format(
          "policy {} by uid {}: image SHA-256 {} -> {}{}; kept the state of {} device(s) and {} "
          "task(s), command(s), rate limit(s) and invariant(s); {}{}",
          b->policy, uid, old_hash, hash, signed_by->empty() ? "" : ", " + *signed_by,
          p.devices.size(),
          p.paired + static_cast<size_t>(std::count(p.kept.begin(), p.kept.end(), true)),
          p.afresh.empty() ? "nothing started afresh"
                           : fmt::format("started afresh: {}", fmt::join(p.afresh, ", ")),
          r.staged_dropped == 0
              ? ""
              : fmt::format("; {} staged register write(s) of tasks the new policy does not "
                            "keep dropped",
                            r.staged_dropped));
      return detail;
    };
    auto applied = server_.apply_reload(std::move(tasks), bindings, source, hash, [&] {
      return trusted_.monitor->reload(*next, std::move(policy), carry);
    });
    if (!applied.ok()) {
      if (reloaded_) reloaded_(old_hash);  // the reload's record was not written: back
      return refuse(EBUSY, applied.error());
    }
    // The monitor decides with `next` now: the old core is no longer used.
    trusted_.decider = std::move(next);
    trusted_.model = std::move(*model);
    trusted_.image_sha256 = hash;
    trusted_.source = source;
    trusted_.bindings = std::move(bindings);
    trusted_.tasks.clear();
    for (size_t i = 0; i < trusted_.model.tasks.size(); ++i) {
      trusted_.tasks[trusted_.model.tasks[i].name] = static_cast<uint16_t>(i);
    }
    std::string text = "reloaded: " + *applied;
    for (const auto& w : warnings) text += "\nwarning: " + w;
    return {0, text};
  }

  const monitor::SetupOptions& options_;
  monitor::Trusted& trusted_;
  Server& server_;
  std::function<void(const std::string&)> reloaded_;
  std::mutex mu_;
};

}  // namespace

Server::Reloader make_reloader(const monitor::SetupOptions& options, monitor::Trusted& trusted,
                               Server& server, std::function<void(const std::string&)> reloaded) {
  auto r = std::make_shared<Reloader>(options, trusted, server, std::move(reloaded));
  return [r](const gate::wire::ReloadRequest& request, uid_t uid) { return (*r)(request, uid); };
}

}  // namespace contego::cli
