#include "perf/rig.h"

#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <string_view>

#include "base/clock.h"
#include "gate/socket_client.h"
#include "intercept/seccomp/supervisor.h"

namespace contego::perf::detail {

const std::map<std::string, uint16_t>& task_ids() {
  static const std::map<std::string, uint16_t> ids = {
      {"follower", 0}, {"gripper", 1}, {"burst", 2}};
  return ids;
}

// Paths through the separate monitor process.
bool is_remote(Path p) {
  return p == Path::kPreload || p == Path::kSeccompMonitor || p == Path::kPreloadSocket ||
         p == Path::kSeccompMonitorSocket;
}

std::map<std::string, uint16_t> server_tasks(const Workload& w) {
  if (w.image.empty()) return task_ids();
  return {{w.task, w.task_id}};
}

// Decisions recorded so far in an audit log, by outcome.
std::map<std::string, uint64_t> decisions_in(const std::string& path) {
  std::ifstream in(path);
  return monitor::verify_audit(in).summary.by_decision;
}

std::map<std::string, uint64_t> minus(std::map<std::string, uint64_t> after,
                                      const std::map<std::string, uint64_t>& before) {
  for (auto& [k, v] : after) {
    auto it = before.find(k);
    if (it != before.end()) v -= std::min(v, it->second);
  }
  std::erase_if(after, [](const auto& kv) { return kv.second == 0; });
  return after;
}

std::string hex(const std::vector<uint8_t>& bytes) {
  std::string s;
  for (uint8_t b : bytes) s += fmt::format("{:02x}", b);
  return s;
}

// The pause between two jobs (relative, like the task program's: every
// pause is long enough to end a job at the monitor).
void next_job(uint32_t period_us) {
  timespec left{static_cast<time_t>(period_us / 1000000),
                static_cast<long>(period_us % 1000000) * 1000};
  while (nanosleep(&left, &left) != 0 && errno == EINTR) {
  }
}

std::string pinning_line(int cpu) {
  if (cpu < 0) return {};
  return fmt::format(
      "pinned: on b, c1 and c2 the task (and on c1 and c2 its supervisor) ran on CPU {} only, as "
      "with `contego run --cpu {}`\n",
      cpu, cpu);
}

Status check_cpu(int cpu) {
  if (cpu < 0) return {};
  cpu_set_t allowed;
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) {
    return make_error(std::string("sched_getaffinity: ") + strerror(errno));
  }
  if (cpu >= CPU_SETSIZE || !CPU_ISSET(cpu, &allowed)) {
    return make_error(fmt::format("--cpu {}: not a CPU this process may run on", cpu));
  }
  return {};
}

Result<std::vector<uint64_t>> read_samples(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error("the bench task wrote no results to " + path);
  std::vector<uint64_t> v;
  uint64_t x;
  while (in.read(reinterpret_cast<char*>(&x), sizeof x)) v.push_back(x);
  return v;
}

// Runs the task program and reads its samples. exit 2 = some writes failed.
Result<std::vector<uint64_t>> finish_task(int exit_code, const std::string& out,
                                          uint64_t* failures) {
  if (exit_code != 0 && exit_code != 2) {
    return make_error(fmt::format("the bench task exited with status {}", exit_code));
  }
  if (exit_code == 2 && failures != nullptr) *failures = 1;
  return read_samples(out);
}

Result<std::vector<uint64_t>> run_seccomp(const std::vector<std::string>& argv,
                                          gate::Endpoint& endpoint, uint16_t task,
                                          uint64_t* failures, int cpu) {
  intercept::seccomp::Options so;
  so.task = task;
  so.cpu = cpu;
  so.argv = argv;
  auto r = intercept::seccomp::run(so, endpoint);
  if (!r.ok()) return make_error(r.error());
  return finish_task(r->exit_code, argv[5], failures);
}

Result<std::vector<uint64_t>> run_over_socket(const std::string& socket, const Workload& w,
                                              const std::vector<std::string>& argv,
                                              uint64_t* failures, const Transport& how) {
  std::optional<gate::SpinPolicy> channel;
  if (how.channel) {
    channel = gate::SpinPolicy{};
    channel->spin_us = how.spin_us;
  }
  auto c = gate::SocketClient::connect(socket, w.task, channel);
  if (!c.ok()) return make_error(c.error());
  if (how.channel != (*c)->uses_channel()) {
    return make_error("the monitor process did not " +
                      std::string(how.channel ? "open a channel" : "stay on the socket"));
  }
  intercept::seccomp::Options so;
  so.task = (*c)->task_id();
  so.cpu = how.cpu;
  so.argv = argv;
  if (how.realtime) so.realtime_priority = (*c)->task_priority();
  auto r = intercept::seccomp::run(so, **c);
  if (!r.ok()) return make_error(r.error());
  if (how.realtime && !r->realtime) {
    return make_error("SCHED_FIFO refused: " + r->realtime_error);
  }
  return finish_task(r->exit_code, argv[5], failures);
}

Result<std::vector<uint64_t>> run_preload(const std::string& preload_lib, uint32_t spin_us,
                                          const std::string& socket, const Workload& w,
                                          const std::vector<std::string>& argv, uint64_t* failures,
                                          bool channel, int cpu) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The task's environment is built here, before the fork: the bench has
  // other threads, and a child of a threaded process must not allocate (a
  // lock another thread held at the fork stays held in the child, as
  // with a sanitizer's allocator, and the child never gets to exec).
  const std::vector<std::string> set = {"LD_PRELOAD=" + preload_lib, "CONTEGO_SOCKET=" + socket,
                                        "CONTEGO_TASK=" + w.task,
                                        std::string("CONTEGO_CHANNEL=") + (channel ? "1" : "0"),
                                        "CONTEGO_SPIN_US=" + std::to_string(spin_us)};
  std::vector<char*> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string_view entry(*e);
    const bool replaced = std::any_of(set.begin(), set.end(), [&](const std::string& v) {
      return entry.substr(0, entry.find('=') + 1) == std::string_view(v).substr(0, v.find('=') + 1);
    });
    if (!replaced) env.push_back(*e);
  }
  for (const std::string& v : set) env.push_back(const_cast<char*>(v.c_str()));
  env.push_back(nullptr);
  fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return make_error(std::string("fork: ") + strerror(errno));
  if (pid == 0) {
    if (cpu >= 0) {
      cpu_set_t one;
      CPU_ZERO(&one);
      CPU_SET(cpu, &one);
      if (sched_setaffinity(0, sizeof one, &one) != 0) _exit(126);
    }
    execve(args[0], args.data(), env.data());
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return finish_task(WIFEXITED(status) ? WEXITSTATUS(status) : 128, argv[5], failures);
}

}  // namespace contego::perf::detail
