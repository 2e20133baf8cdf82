// What `contego bench` and its per-job mode share (see overhead.h, per_job.h):
// the monitor rigs, the separate monitor process, and running the timed task
// program on each path. Internal to contego_perf.
#ifndef CONTEGO_PERF_RIG_H_
#define CONTEGO_PERF_RIG_H_

#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstring>
#include <fmt/core.h>
#include <map>
#include <memory>
#include <string>
#include <sys/wait.h>
#include <vector>

#include "bus/virtual_bus.h"
#include "gate/endpoint.h"
#include "gate/socket.h"
#include "monitor/audit_log.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "monitor/server.h"
#include "perf/overhead.h"

namespace contego::perf::detail {

const std::map<std::string, uint16_t>& task_ids();

std::map<std::string, uint16_t> server_tasks(const Workload& w);

// Allows every command and emits it unchanged, with its audit line: the
// cost of a decision without the cost of a particular policy.
class PassDecider final : public monitor::Decider {
 public:
  void set_host(const core::Host& host) override { host_ = host; }
  void check(const core::Transaction& tx, core::Verdict* v) override {
    v->decision = core::Decision::kAllow;
    v->reason = core::Reason{};
    v->bus = tx.bus;
    v->addr = tx.addr;
    v->emit_count = 0;
    v->emit_bytes_used = 0;
    if (tx.kind == core::TxKind::kWrite) {
      v->emit_count = 1;
      v->emit_len[0] = static_cast<uint16_t>(tx.len);
      std::memcpy(v->emit_bytes, tx.bytes, tx.len);
      v->emit_bytes_used = static_cast<uint16_t>(tx.len);
    }
    core::AuditRecord r{};
    r.task = tx.task;
    r.job = tx.job;
    r.decision = v->decision;
    r.bus = tx.bus;
    r.addr = tx.addr;
    r.original = tx.bytes;
    r.original_len = static_cast<uint16_t>(tx.len);
    if (host_.audit != nullptr) host_.audit(host_.context, &r);
  }
  bool safe_state(uint16_t, core::Verdict*) override { return false; }
  uint32_t device_count() const override { return 0; }
  const core::DeviceRecord& device(uint16_t) const override { return none_; }
  uint32_t task_period_us(uint16_t) const override { return period_us_; }
  // The DoS measure's follower outranks everything else (the burst has none).
  uint16_t task_priority(uint16_t task) const override { return task == 0 ? 20 : 0; }
  uint32_t task_actuations_per_job(uint16_t) const override { return actuations_; }
  // Every task declares this period and one actuation per job (the DoS
  // measure with the monitor's over-budget hold).
  void declare(uint32_t period_us) {
    period_us_ = period_us;
    actuations_ = 1;
  }

 private:
  core::Host host_{};
  core::DeviceRecord none_{};
  uint32_t period_us_ = 20000;
  uint32_t actuations_ = 0;
};

// A monitor with the virtual bus and its device models, auditing to a file
// (an empty path: no log, bench/monitor_bench's baseline), decided by the
// workload's policy in the real core or by PassDecider.
class Rig {
 public:
  static Result<std::unique_ptr<Rig>> make(const std::string& audit_path, const Workload& w,
                                           Clock& clock = MonotonicClock::instance()) {
    std::unique_ptr<Rig> r(new Rig);
    if (!audit_path.empty()) {
      if (Status s = r->audit.open(audit_path); !s.ok()) return make_error(s.error());
    }
    r->bus.attach(std::make_shared<bus::Pca9685>());
    r->bus.attach(std::make_shared<bus::GoPiGo2>());
    auto line = std::make_shared<bus::LineFollower>();
    // Each sensor halfway between its white and black calibration in
    // rover.policy: the line is under the middle sensor (pos 0), the state
    // in which the rover's invariant INV3 (go forward) applies.
    line->set_values({889, 914, 937, 856, 852});
    r->bus.attach(line);
    monitor::Decider* decider = &r->pass_;
    std::vector<std::string> names(task_ids().size());
    for (const auto& [name, id] : task_ids()) names[id] = name;
    if (!w.image.empty()) {
      r->core_ = std::make_unique<monitor::CoreDecider>();
      const core::LoadResult lr =
          r->core_->checker().load(w.image.data(), static_cast<uint32_t>(w.image.size()));
      if (lr.status != core::LoadStatus::kOk) {
        return make_error(fmt::format("{}: the policy image was refused ({})", w.name,
                                      core::load_status_name(lr.status)));
      }
      decider = r->core_.get();
      names.assign(std::max<size_t>(w.task_id + 1u, 1u), "");
      names[w.task_id] = w.task;
      r->policy_ = true;
    }
    r->mon = std::make_unique<monitor::Monitor>(*decider, r->audit, clock);
    r->mon->add_bus(1, &r->bus);
    r->mon->set_task_names(names);
    return r;
  }
  // Samples the sensors now and then on their periods (policy rigs only).
  // Starts a thread: call after the last fork of a monitor process.
  void start() {
    if (!policy_) return;
    mon->sample_all();
    mon->start_sampling();
  }
  ~Rig() {
    if (mon) mon->stop_sampling();
  }

  PassDecider& pass() { return pass_; }

  bus::VirtualBus bus;
  monitor::AuditLog audit;
  std::unique_ptr<monitor::Monitor> mon;

 private:
  Rig() = default;
  PassDecider pass_;
  std::unique_ptr<monitor::CoreDecider> core_;
  bool policy_ = false;
};

struct TempDir {
  TempDir() {
    char tmpl[] = "/tmp/contego-bench-XXXXXX";
    if (mkdtemp(tmpl) != nullptr) path = tmpl;
  }
  ~TempDir() {
    if (!path.empty()) (void)!system(("rm -rf '" + path + "'").c_str());
  }
  std::string path;
};

// The separate monitor process. Forked before this process starts threads.
class MonitorProcess {
 public:
  // budget_period_us > 0: every task declares that period and one actuation
  // per job, and the monitor holds a task past its budget (the CLI's default
  // factor).
  Status start(const std::string& dir, const std::string& name, const Workload& w, uint32_t spin_us,
               bool realtime = false, uint32_t budget_period_us = 0) {
    socket_ = dir + "/" + name + ".sock";
    audit_ = dir + "/" + name + "-audit.jsonl";
    fflush(nullptr);
    pid_ = fork();
    if (pid_ < 0) return make_error(std::string("fork: ") + strerror(errno));
    if (pid_ == 0) {
      auto rig = Rig::make(audit_, w);
      if (!rig.ok()) _exit(1);
      if (budget_period_us > 0) {
        (*rig)->pass().declare(budget_period_us);
        (*rig)->mon->set_budget_factor(monitor::Monitor::kDefaultBudgetFactor);
      }
      (*rig)->start();
      gate::SpinPolicy spin;
      spin.spin_us = spin_us;
      monitor::Server server(*(*rig)->mon, (*rig)->audit, server_tasks(w), {getuid()}, spin,
                             realtime);
      if (!server.listen(socket_).ok()) _exit(1);
      server.serve();
      _exit(0);
    }
    // Ready when a connection is accepted.
    for (int i = 0; i < 500; ++i) {
      if (gate::connect_to_monitor(socket_).ok()) return {};
      usleep(10000);
    }
    return make_error("the monitor process did not come up at " + socket_);
  }
  ~MonitorProcess() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  const std::string& socket() const { return socket_; }
  const std::string& audit() const { return audit_; }

 private:
  pid_t pid_ = -1;
  std::string socket_, audit_;
};

// How a supervised bench task reaches the monitor process.
struct Transport {
  bool channel = true;     // else the socket alone
  uint32_t spin_us = 100;  // the channel's client spin
  bool realtime = false;   // program and supervisor under SCHED_FIFO at the task's priority
  int cpu = -1;            // >= 0: program and supervisor on this CPU only (contego run --cpu)
};

// Paths through the separate monitor process.
bool is_remote(Path p);

// Decisions recorded so far in an audit log, by outcome.
std::map<std::string, uint64_t> decisions_in(const std::string& path);

std::map<std::string, uint64_t> minus(std::map<std::string, uint64_t> after,
                                      const std::map<std::string, uint64_t>& before);

std::string hex(const std::vector<uint8_t>& bytes);

// The pause between two jobs (relative, like the task program's: every
// pause is long enough to end a job at the monitor).
void next_job(uint32_t period_us);

Result<std::vector<uint64_t>> read_samples(const std::string& path);

// The report's line on where the task ran ("" when not pinned).
std::string pinning_line(int cpu);

// Fails unless `cpu` (>= 0) is one this process may run on; -1 passes.
Status check_cpu(int cpu);

// Runs the task program and reads its samples. exit 2 = some writes failed.
Result<std::vector<uint64_t>> finish_task(int exit_code, const std::string& out,
                                          uint64_t* failures);

Result<std::vector<uint64_t>> run_seccomp(const std::vector<std::string>& argv,
                                          gate::Endpoint& endpoint, uint16_t task,
                                          uint64_t* failures, int cpu = -1);

Result<std::vector<uint64_t>> run_over_socket(const std::string& socket, const Workload& w,
                                              const std::vector<std::string>& argv,
                                              uint64_t* failures, const Transport& how);

Result<std::vector<uint64_t>> run_preload(const std::string& preload_lib, uint32_t spin_us,
                                          const std::string& socket, const Workload& w,
                                          const std::vector<std::string>& argv, uint64_t* failures,
                                          bool channel, int cpu = -1);

}  // namespace contego::perf::detail

#endif  // CONTEGO_PERF_RIG_H_
