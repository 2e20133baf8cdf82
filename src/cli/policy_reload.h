// `contego reload` in the trusted daemon: a bundle sent over the socket is
// verified (its minisign signature with the trusted keys; required with
// --require-signed), loaded into a fresh core, paired with the running
// policy by name and swapped in between two transfers, sessions and state
// kept (Monitor::reload, Server::apply_reload, core::Checker::carry_from).
//
// What a reload keeps: the devices must be the running policy's (the same
// names, buses, addresses and profiles, in the same order); a task keeps its
// job grid, budget, readings and core state when the new policy has it under
// the same name and id, and a task with live sessions must; a command, rate
// limit or invariant keeps its state when the new policy has one of that
// name on the same device (and task). Everything else starts afresh, and the
// `reload` record names it, with both images' SHA-256.
#ifndef CONTEGO_CLI_POLICY_RELOAD_H_
#define CONTEGO_CLI_POLICY_RELOAD_H_

#include <functional>
#include <string>

#include "cli/trusted_setup.h"
#include "monitor/server.h"

namespace contego::cli {

// The daemon's Server::Reloader. `options` are the daemon's own (keys,
// --require-signed, budget factor, complain scope); `trusted` is updated in
// place; `reloaded(sha256)` runs as a reload takes effect, before its
// record is written (the journal names the new image from the reload's own
// entry on), and again with the old hash if that record could not be
// written. The returned function serialises reloads.
monitor::Server::Reloader make_reloader(const monitor::SetupOptions& options,
                                        monitor::Trusted& trusted, monitor::Server& server,
                                        std::function<void(const std::string&)> reloaded);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_POLICY_RELOAD_H_
