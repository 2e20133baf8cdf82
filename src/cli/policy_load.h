// The tool's side of loading a policy: compiling a policy source, which the
// trusted daemon (contego-monitor) never does. `contego run` and the tests
// start the trusted side in process from a policy; `contego monitor`
// compiles here and hands contego-monitor a bundle.
#ifndef CONTEGO_CLI_POLICY_LOAD_H_
#define CONTEGO_CLI_POLICY_LOAD_H_

#include <memory>

#include "base/result.h"
#include "bundle/bundle.h"
#include "cli/trusted_setup.h"
#include "policy/compile.h"

namespace contego::monitor {

// The image to enforce: compiled from `policy` (an `image` given too must be
// what it compiles to), or what load_verified() loads.
Result<LoadedPolicy> load_policy(const SetupOptions& options);

// load_policy() then setup().
Result<std::unique_ptr<Trusted>> setup(const SetupOptions& options);

// The bundle of a loaded policy: its image and bindings, named `policy`.
bundle::Bundle bundle_of(const LoadedPolicy& loaded, const std::string& policy);

// The task bindings a compiled policy declares, as a bundle carries them.
std::vector<bundle::BundleTask> bundle_tasks(const policy::PolicySummary& summary);

}  // namespace contego::monitor

#endif  // CONTEGO_CLI_POLICY_LOAD_H_
