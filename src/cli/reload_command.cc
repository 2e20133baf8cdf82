// `contego reload (--policy FILE | --bundle FILE [--signature SIG]) [--socket PATH]`:
// the running monitor enforces a new policy in place, its sessions and their
// state kept (cli/policy_reload.h says what carries over). A policy file is
// compiled here and sent as a bundle; a bundle file is sent with its minisign
// signature (SIG, default FILE.minisig when it exists), which a monitor
// started with --require-signed requires. Root or the monitor's uid. Exit
// 0 when the new policy is in force, 1 when the monitor refused it (the old
// one stays), 2 for a policy that does not compile or a monitor that cannot
// be reached.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <sys/stat.h>

#include "base/read_file.h"
#include "bundle/bundle.h"
#include "cli/command.h"
#include "cli/policy_load.h"
#include "gate/operator.h"

namespace contego::cli {

void register_reload(CLI::App& app) {
  struct Args {
    std::string policy, bundle, signature, socket = "/run/contego/monitor.sock";
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "reload",
      "Replace the running monitor's policy in place, sessions and state kept (root or the "
      "monitor's uid)");
  auto* policy = cmd->add_option("--policy", args->policy, "policy file: compiled here, then sent");
  auto* bundle = cmd->add_option("--bundle", args->bundle,
                                 "a policy bundle (`contego check --emit-bundle`), sent as is");
  policy->excludes(bundle);
  cmd->add_option("--signature", args->signature,
                  "the bundle's minisign signature (default: BUNDLE.minisig when it exists)")
      ->needs(bundle);
  cmd->add_option("--socket", args->socket, "the monitor's Unix socket")->capture_default_str();
  cmd->callback([args] {
    auto fail = [](const std::string& why, int code) {
      fmt::print(stderr, "contego reload: {}\n", why);
      return set_exit_code(code);
    };
    if (args->policy.empty() && args->bundle.empty()) {
      return fail("give --policy FILE or --bundle FILE", 2);
    }
    std::string text, signature;
    if (!args->policy.empty()) {
      monitor::SetupOptions o;
      o.policy = args->policy;
      auto loaded = monitor::load_policy(o);
      if (!loaded.ok()) return fail(loaded.error(), 2);
      text = bundle::encode_bundle(monitor::bundle_of(*loaded, args->policy));
    } else {
      auto read = read_input_file(args->bundle);
      if (!read.ok()) return fail("bundle " + read.error(), 2);
      text = *read;
      const std::string sig = args->signature.empty() ? args->bundle + ".minisig" : args->signature;
      struct stat st {};
      if (!args->signature.empty() || ::stat(sig.c_str(), &st) == 0) {
        auto s = read_input_file(sig);
        if (!s.ok()) return fail("signature " + s.error(), 2);
        signature = *s;
      }
    }
    const Result<std::string> r = gate::request_reload(args->socket, text, signature);
    if (!r.ok()) {
      const bool unreachable = r.error().find("cannot reach") != std::string::npos;
      return fail(r.error(), unreachable ? 2 : 1);
    }
    fmt::print("contego reload: {}\n", *r);
  });
}

}  // namespace contego::cli
