#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "cli/command.h"
#include "cli/trusted_setup.h"
#include "gate/socket.h"
#include "intercept/seccomp/supervisor.h"

namespace contego::cli {

void register_run(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "run", "Run an unmodified program with every bus command checked (seccomp supervisor)");
  struct Args {
    std::string policy, task, socket, audit = "-";
    std::map<int, std::string> buses;
    std::vector<int> virtual_buses;
    std::vector<std::string> program;
    uint32_t spin_us = gate::SpinPolicy{}.spin_us;
    bool no_channel = false;
    bool realtime = false;
    uint32_t budget_factor = monitor::Monitor::kDefaultBudgetFactor;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--policy", args->policy, "policy file (embedded monitor)");
  cmd->add_option("--task", args->task, "the program's task name in the policy")->required();
  cmd->add_option("--socket", args->socket, "use the monitor daemon at this socket instead");
  cmd->add_option("--audit", args->audit, "audit log of the embedded monitor (- = stderr)");
  cmd->add_option("--bus", args->buses, "N=/dev/i2c-N: a real adapter (embedded monitor)");
  cmd->add_option("--virtual-bus", args->virtual_buses, "N: a virtual bus with device models");
  cmd->add_option("--spin-us", args->spin_us,
                  "with --socket: busy-wait this long for the monitor's answer before sleeping")
      ->check(CLI::Range(0u, gate::kMaxSpinUs))
      ->capture_default_str();
  cmd->add_flag("--no-channel", args->no_channel,
                "with --socket: talk over the socket only, no shared-memory channel");
  cmd->add_option("--budget-factor", args->budget_factor,
                  "hold a task's transfers to the end of its period once it has sent more than "
                  "this many times its declared actuations in one job (0 = never)")
      ->capture_default_str();
  cmd->add_flag(
      "--rt", args->realtime,
      "run the program and its supervisor under SCHED_FIFO at the task's policy priority");
  cmd->add_option("program", args->program, "program and its arguments (after --)")->required();
  cmd->callback([args] {
    intercept::seccomp::Options opt;
    opt.argv = args->program;
    if (!args->socket.empty()) {
      std::optional<gate::SpinPolicy> channel;
      if (!args->no_channel) {
        channel = gate::SpinPolicy{};
        channel->spin_us = args->spin_us;
      }
      auto client = gate::SocketClient::connect(args->socket, args->task, channel);
      if (!client.ok()) {
        fmt::print(stderr, "contego run: {}\n", client.error());
        return set_exit_code(2);
      }
      opt.task = (*client)->task_id();
      if (args->realtime) opt.realtime_priority = (*client)->task_priority();
      if (args->realtime && opt.realtime_priority == 0) {
        fmt::print(stderr, "contego run: --rt: task '{}' has no priority in the policy\n",
                   args->task);
      }
      auto r = intercept::seccomp::run(opt, **client);
      if (!r.ok()) {
        fmt::print(stderr, "contego run: {}\n", r.error());
        return set_exit_code(2);
      }
      if (!r->realtime_error.empty()) {
        fmt::print(stderr, "contego run: --rt refused ({}); ran without it\n", r->realtime_error);
      }
      return set_exit_code(r->exit_code);
    }
    if (args->policy.empty()) {
      fmt::print(stderr, "contego run: give --policy (embedded monitor) or --socket\n");
      return set_exit_code(2);
    }
    monitor::SetupOptions so;
    so.policy = args->policy;
    so.audit = args->audit;
    so.real_buses = args->buses;
    so.virtual_buses = args->virtual_buses;
    so.budget_factor = args->budget_factor;
    if (so.real_buses.empty() && so.virtual_buses.empty()) so.virtual_buses = {1};
    auto trusted = monitor::setup(so);
    if (!trusted.ok()) {
      fmt::print(stderr, "contego run: {}\n", trusted.error());
      return set_exit_code(2);
    }
    auto it = (*trusted)->tasks.find(args->task);
    if (it == (*trusted)->tasks.end()) {
      fmt::print(stderr, "contego run: policy {} declares no task '{}'\n", args->policy,
                 args->task);
      return set_exit_code(2);
    }
    opt.task = it->second;
    if (args->realtime) opt.realtime_priority = (*trusted)->monitor->task_priority(opt.task);
    if (args->realtime && opt.realtime_priority == 0) {
      fmt::print(stderr, "contego run: --rt: task '{}' has no priority in the policy\n",
                 args->task);
    }
    auto r = intercept::seccomp::run(opt, *(*trusted)->monitor);
    (*trusted)->monitor->stop_sampling();
    if (!r.ok()) {
      fmt::print(stderr, "contego run: {}\n", r.error());
      return set_exit_code(2);
    }
    if (!r->realtime_error.empty()) {
      fmt::print(stderr, "contego run: --rt refused ({}); ran without it\n", r->realtime_error);
    }
    set_exit_code(r->exit_code);
  });
}

}  // namespace contego::cli
