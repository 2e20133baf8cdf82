#include "cli/policy_load.h"

#include <fmt/format.h>

#include "base/read_file.h"
#include "monitor/sha256.h"

namespace contego::monitor {
namespace {

std::string hash_of(const std::vector<uint8_t>& image) {
  return sha256_hex(std::string_view(reinterpret_cast<const char*>(image.data()), image.size()));
}

}  // namespace

Result<LoadedPolicy> load_policy(const SetupOptions& o) {
  if (o.policy.empty()) return load_verified(o);
  policy::CompileOutput compiled = policy::compile_file(o.policy);
  if (!compiled.ok) {
    std::string msg = "policy " + o.policy + " does not compile:";
    for (const auto& d : compiled.diagnostics) msg += "\n" + d.rendered;
    return make_error(msg);
  }
  LoadedPolicy p;
  p.bindings = bundle_tasks(compiled.summary);
  const std::string hash = hash_of(compiled.image);
  if (!o.image.empty()) {
    // An image beside its policy: used only if it is what the policy compiles to.
    auto bytes = read_input_file(o.image);
    if (!bytes.ok()) return make_error("image " + bytes.error());
    if (!o.image_sha256.empty() && sha256_hex(*bytes) != o.image_sha256) {
      return make_error(
          fmt::format("image {} has SHA-256 {}; --image-sha256 expects {}: refusing it", o.image,
                      sha256_hex(*bytes), o.image_sha256));
    }
    if (std::string_view(reinterpret_cast<const char*>(compiled.image.data()),
                         compiled.image.size()) != *bytes) {
      return make_error(fmt::format(
          "image {} (SHA-256 {}) is not the image policy {} compiles to (SHA-256 {}): refusing it",
          o.image, sha256_hex(*bytes), o.policy, hash));
    }
    p.source = fmt::format("{} (SHA-256 {})", o.image, hash);
  } else {
    // The image's hash names what is enforced, in the start record and the
    // status, as for an image given with --image.
    p.source = fmt::format("{} (SHA-256 {})", o.policy, hash);
  }
  p.image = std::move(compiled.image);
  p.model = std::move(compiled.model);
  return p;
}

Result<std::unique_ptr<Trusted>> setup(const SetupOptions& o) {
  auto loaded = load_policy(o);
  if (!loaded.ok()) return make_error(loaded.error());
  return setup(o, *loaded);
}

std::vector<bundle::BundleTask> bundle_tasks(const policy::PolicySummary& summary) {
  std::vector<bundle::BundleTask> tasks;
  for (const auto& t : summary.tasks) {
    tasks.push_back(
        {t.name, t.exe, t.user, t.group, t.unit, t.cgroup, t.sessions, t.phase_us, t.ignore_errno});
  }
  return tasks;
}

bundle::Bundle bundle_of(const LoadedPolicy& loaded, const std::string& policy) {
  return bundle::Bundle{policy, loaded.image, loaded.bindings, loaded.budget_factor, loaded.buses};
}

}  // namespace contego::monitor
