#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <thread>

#include "cli/command.h"
#include "cli/trusted_setup.h"
#include "monitor/server.h"

namespace contego::cli {

void register_monitor(CLI::App& app) {
  auto* cmd = app.add_subcommand("monitor", "The trusted-side daemon: sole owner of the buses");
  struct Args {
    std::string policy, socket = "/run/contego/monitor.sock", audit = "-";
    std::map<int, std::string> buses;
    std::vector<int> virtual_buses;
    std::vector<unsigned> uids;
    uint32_t spin_us = gate::SpinPolicy{}.spin_us;
    bool realtime = false;
    uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--policy", args->policy, "policy file")->required();
  cmd->add_option("--socket", args->socket, "Unix socket to serve");
  cmd->add_option("--audit", args->audit, "audit log (JSON lines; - = stderr)");
  cmd->add_option("--bus", args->buses, "N=/dev/i2c-N: a real adapter");
  cmd->add_option("--virtual-bus", args->virtual_buses, "N: a virtual bus with device models");
  cmd->add_option("--client-uid", args->uids, "uid allowed to connect (default: own uid, root)");
  cmd->add_option("--spin-us", args->spin_us,
                  "busy-wait this long for a channel client's next request before sleeping")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  cmd->add_option("--budget-factor", args->budget_factor,
                  "hold a task's transfers to the end of its period once it has sent more than "
                  "this many times its declared actuations in one job (0 = never)")
      ->capture_default_str();
  cmd->add_flag("--rt", args->realtime,
                "serve each connection under SCHED_FIFO at its task's policy priority");
  cmd->callback([args] {
    // SIGINT/SIGTERM are taken by a waiting thread, which stops the server.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    monitor::SetupOptions so;
    so.policy = args->policy;
    so.audit = args->audit;
    so.real_buses = args->buses;
    so.virtual_buses = args->virtual_buses;
    so.budget_factor = args->budget_factor;
    if (so.real_buses.empty() && so.virtual_buses.empty()) {
      fmt::print(stderr, "contego monitor: give at least one --bus or --virtual-bus\n");
      return set_exit_code(2);
    }
    auto trusted = monitor::setup(so);
    if (!trusted.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", trusted.error());
      return set_exit_code(2);
    }
    std::set<uid_t> uids{getuid(), 0};
    for (unsigned u : args->uids) uids.insert(u);
    gate::SpinPolicy spin;
    spin.spin_us = args->spin_us;
    monitor::Server server(*(*trusted)->monitor, (*trusted)->audit, (*trusted)->tasks, uids, spin,
                           args->realtime);
    if (Status s = server.listen(args->socket); !s.ok()) {
      fmt::print(stderr, "contego monitor: {}\n", s.error());
      return set_exit_code(2);
    }
    fmt::print(stderr, "contego monitor: serving {} on {}\n", args->policy, args->socket);
    std::thread waiter([&] {
      int sig = 0;
      sigwait(&set, &sig);
      server.stop();
    });
    server.serve();
    (*trusted)->monitor->drive_safe_state("monitor stopping");
    (*trusted)->monitor->stop_sampling();
    pthread_kill(waiter.native_handle(), SIGTERM);
    waiter.join();
  });
}

}  // namespace contego::cli
