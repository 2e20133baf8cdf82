// Monitor: the trusted side on Linux. Sole owner of the bus backends; every
// transfer an enclave client sends is normalised into core transactions,
// decided by the core, and only the bytes the core emitted are put on the
// bus. Samples the declared sensors itself and keeps every sensor reading a
// task had it perform (S(t) never comes from a task's say-so: each reading is
// bytes the monitor read from the bus; readings/sensor_readings.h), numbers each
// task's jobs on its period grid from the monitor's own clock, writes the
// audit log, and drives every actuator to its safe state on start, on a fault
// and when a supervised task exits.
//
// Thread-safety: all public methods may be called from any thread; one mutex
// serialises the core and the buses (the core is single-threaded by design).
#ifndef CONTEGO_MONITOR_MONITOR_H_
#define CONTEGO_MONITOR_MONITOR_H_

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "contego/core/limits.h"
#include "contego/job_budget.h"

#include "base/clock.h"
#include "base/mutex.h"
#include "bus/bus.h"
#include "gate/endpoint.h"
#include "monitor/audit_log.h"
#include "monitor/decider.h"
#include "monitor/drop_report.h"
#include "readings/sensor_readings.h"

namespace contego::monitor {

// The release of a task's job 1 when its first contact with the monitor is at
// `contact_us`: the contact itself, or with a declared phase (the policy's
// `phase`) the latest release phase + k·period (k >= 0) at or before the
// contact, on the monitor's monotonic clock (CLOCK_MONOTONIC): the grid a
// task that sleeps with clock_nanosleep(TIMER_ABSTIME) on that clock keeps.
uint64_t first_release_us(std::optional<uint64_t> phase_us, uint64_t period_us,
                          uint64_t contact_us);

// The wall-clock cost of deciding transfers (`contego status`, the metrics'
// contego_check_duration_seconds histogram).
inline constexpr std::array<uint64_t, 9> kCheckCostBoundsNs = {1000,  2000,   5000,   10000,  20000,
                                                               50000, 100000, 250000, 1000000};
struct CheckCost {
  std::array<uint64_t, kCheckCostBoundsNs.size() + 1> counts{};
  uint64_t sum_ns = 0;
  uint64_t count = 0;
  void add(uint64_t ns) {
    size_t i = 0;
    while (i < kCheckCostBoundsNs.size() && ns > kCheckCostBoundsNs[i]) ++i;
    ++counts[i];
    sum_ns += ns;
    ++count;
  }
};

// A device the monitor could not read or drive: its id in the image and the
// bus's errno (ENODEV: no adapter for its bus).
struct DeviceFailure {
  uint16_t device = 0;
  int err = 0;
};

class Monitor final : public gate::Endpoint {
 public:
  // `decider`, `audit`, `clock` and the buses must outlive the monitor. The
  // monitor reads time only from `clock` (job grids, reading ages, budget
  // holds, sampling) and touches devices only through its buses, so a
  // simulator can run it in virtual time on virtual buses.
  Monitor(Decider& decider, AuditLog& audit, Clock& clock = MonotonicClock::instance());
  ~Monitor() override;

  void add_bus(uint8_t number, bus::Bus* bus);
  void set_task_names(std::vector<std::string> names) {
    base::MutexLock lock(mu_);
    names_.tasks = std::move(names);
  }
  // The image's names, written beside the numbers of every audit record.
  void set_names(NameTable names) {
    base::MutexLock lock(mu_);
    names_ = std::move(names);
  }
  // Per task id, bit k: the task may actuate device k (the image's access
  // matrix). When set, a task's exit drives only its own actuators safe;
  // unset (or a task beyond the list), every actuator.
  void set_task_devices(std::vector<uint32_t> actuate_masks) {
    base::MutexLock lock(mu_);
    task_devices_ = std::move(actuate_masks);
  }
  // Over-budget hold (0 = off): once `factor` x its declared actuations per
  // job of a task's transfers acted in one job, its next transfer waits until
  // the task's next release; once more than `factor` x max(actuations,
  // kNonActingFloor) of its transfers did not act (ignored, refused, only
  // staged), the thread that sent the last one waits after its answer.
  // The schedulability test assumes N_i checked commands per job; this bounds
  // what a runaway or hostile task can make the monitor do for it.
  void set_budget_factor(uint32_t factor);
  // What the policy says of its tasks beside the image, by task id:
  // declared phases of the job grids (see first_release_us; a grid already
  // started keeps its phase), and `ignore_errno` (a transfer the checks
  // ignored fails with it instead of succeeding; nothing of it acted).
  struct TaskFacts {
    std::map<uint16_t, uint64_t> phases;
    std::array<uint8_t, core::kMaxTasks> ignore_errnos{};
  };
  void set_task_facts(TaskFacts facts);
  static constexpr uint32_t kDefaultBudgetFactor = 4;  // what the CLI sets
  // Non-acting transfers a task may send per job before its sender waits, at
  // factor 1: room for a vendor library's start-up writes that a policy
  // ignores by design (Adafruit's PCA9685 constructor sends 13).
  static constexpr uint32_t kNonActingFloor = 8;
  uint64_t holds() const { return holds_.load(); }

  // Complain mode (`--complain`, `--complain-for NAME`): a transfer of a
  // complaining task, or one whose every message goes to complaining devices,
  // is checked and recorded as in enforce mode, its records marked
  // `complain`, and then acts as the program sent it. The checker keeps the
  // model enforce mode would have (a would-be drop is undone as a drop is),
  // so the recorded verdicts are the ones enforce mode gives this traffic.
  // The safe state at start and on exit is driven as in enforce mode; a
  // latch's or a combined transfer's safe state is not, and a complaining
  // task is never held over its budget (its timing is what is observed).
  struct ComplainScope {
    bool all = false;
    std::vector<bool> tasks;  // by task id
    uint32_t devices = 0;     // bit k: device k
    bool any() const;
  };
  void set_complain(ComplainScope scope);

  // Reload in place (`contego reload`): what the monitor enforces from now
  // on. The caller checked that the new image has the same devices under the
  // same ids. Under the monitor's lock, between two transfers (one in
  // progress finishes under the old policy), `carry` takes the old decider's
  // model into `decider` (already loaded) and returns the `reload` record's
  // detail; the record is written, then `decider` decides. An error from
  // `carry`, or a record that cannot be written, changes nothing. Tasks not
  // `kept` (another task under the same id, or none) start afresh: job grid,
  // budget, readings, decision counts. `decider` must outlive the monitor or
  // the next reload; the old one is no longer used once this returns.
  struct Policy {
    NameTable names;
    std::vector<uint32_t> task_devices;
    ComplainScope complain;
    TaskFacts facts;
    std::vector<bool> kept;  // by task id of the new image
  };
  Result<std::string> reload(Decider& decider, Policy policy,
                             const std::function<Result<std::string>()>& carry);

  // Drives every actuator to its safe state; logs `why`. Returns the
  // actuators whose safe state did not reach the bus (each also audited as a
  // `fault`); the others were driven.
  std::vector<DeviceFailure> drive_safe_state(const std::string& why);
  // `contego reset DEVICE`: clears the device's latch, after an audit
  // event naming who asked. True if it was latched; an error for an unknown
  // device or an event that could not be written (then nothing changes).
  Result<bool> reset_latch(const std::string& device, uid_t uid);
  // Starts / stops the sensor sampling thread (devices with a sample period).
  void start_sampling();
  void stop_sampling();
  // Takes one sample of every sensor now (tests, and the first sample at
  // start). Returns the sensors that could not be read (their signals are
  // unavailable until a later sample succeeds).
  std::vector<DeviceFailure> sample_all();
  // Samples every sensor with a sample period whose next sample is due on the
  // monitor's clock (what the sampling thread does); returns when the next one
  // is due. A simulator in virtual time calls this instead of start_sampling().
  uint64_t sample_due();

  gate::TransferReply transfer(uint16_t task, const gate::Transfer& transfer) override;
  // A hint that the task went to sleep. Jobs are released on the task's
  // period grid, whose phase is the task's first contact (a transfer or this
  // hint); the hint never starts a job itself, so no sleeping thread can
  // grant the task an extra budget.
  void job_boundary(uint16_t task) override;
  void task_exited(uint16_t task) override { task_ended(task, "exited"); }
  // The same end, said how (the audit's words after "task N (name) ").
  void task_ended(uint16_t task, const std::string& how);
  bool has_bus(uint8_t bus) override;
  uint64_t funcs(uint8_t bus) override;

  // The task's current job on its period grid (0: no contact yet, or no period).
  uint32_t job(uint16_t task) const;
  uint16_t task_priority(uint16_t task) const;
  uint64_t decisions() const { return decisions_.load(); }
  // The task's decisions so far: "N allowed, N ignored, N substituted, N refused".
  std::string decision_summary(uint16_t task) const;
  DecisionCounts decision_counts(uint16_t task) const;
  // Where the rate-limited lines about dropped commands go (standard error by
  // default; nullptr: nowhere, as for a bench).
  void set_drop_report(std::FILE* out);
  // Transfers refused because their decision's audit record could not be
  // written (each also drove the safe state).
  uint64_t audit_refusals() const { return audit_refusals_.load(); }
  // Tasks (job, budget use, decisions by verdict), devices (latched),
  // totals: `contego status` (monitor_status.cc). JSON text.
  std::string status_json() const;

 private:
  struct Budget {
    contego_job_budget counts{};  // job, acted, dropped: the shared model's (job_budget.h)
    uint64_t holds_unreported = 0;
    uint64_t reported_at_us = 0;
    bool told = false;  // the first hold was explained on standard error
  };

  static uint32_t host_read_sample(void* ctx, uint16_t device, uint8_t* buf, uint32_t capacity,
                                   uint64_t* taken_at_us);
  static void host_audit(void* ctx, const core::AuditRecord* record);
  // `timing`: the call's (gate::Timing), none for a safe state.
  int perform_emits(const core::Verdict& v, bool ten_bit, const gate::Timing& timing = {})
      REQUIRES(mu_);
  bool complains_locked(uint16_t task, const gate::Transfer& t) const REQUIRES(mu_);
  bool complains_task_locked(uint16_t task) const REQUIRES(mu_);
  // Complain mode: every write of `planned` emits the bytes the program sent.
  int act_as_sent_locked(const gate::Transfer& t, const std::vector<gate::PlannedTx>& planned)
      REQUIRES(mu_);
  // The readings of every sensor as the check of `checking_task_` sees them,
  // as the JSON object of the decision records (readings_json_).
  void describe_readings_locked() REQUIRES(mu_);
  // transfer()'s steps, under mu_ (verdicts_ holds the verdicts).
  int check_transfer(uint16_t task, const gate::Transfer& t,
                     const std::vector<gate::PlannedTx>& planned, size_t* checked) REQUIRES(mu_);
  gate::TransferReply perform_transfer(uint16_t task, const gate::Transfer& t,
                                       const std::vector<gate::PlannedTx>& planned) REQUIRES(mu_);
  bool perform_as_sent(uint16_t task, const gate::Transfer& t,
                       const std::vector<gate::PlannedTx>& planned, gate::TransferReply& reply)
      REQUIRES(mu_);
  int perform_read(uint16_t task, const gate::Transfer& t, const gate::PlannedTx& p,
                   const bus::Msg* write, gate::TransferReply& reply) REQUIRES(mu_);
  void drive_transfer_safe_states(uint16_t task, size_t checked) REQUIRES(mu_);
  int sample_device_locked(uint16_t device) REQUIRES(mu_);  // 0 or the bus's errno
  uint64_t sample_due_locked() REQUIRES(mu_);
  void hold_if_over_budget(uint16_t task);
  uint64_t charge_transfer_locked(uint16_t task, bool acted) REQUIRES(mu_);
  void report_hold_locked(uint16_t task, Budget& b, uint64_t now, uint64_t budget, const char* what)
      REQUIRES(mu_);
  gate::TransferReply decide_and_act_locked(uint16_t task, const gate::Transfer& t, bool* acted)
      REQUIRES(mu_);
  // The task's job at `now_us` on its period grid (1 = the first), starting
  // the grid on the first call; 0 for a task without a period.
  uint32_t job_at_locked(uint16_t task, uint64_t now_us) REQUIRES(mu_);
  // When job `job` + 1 of the task is released (0: never).
  uint64_t next_release_locked(uint16_t task, uint32_t job) const REQUIRES(mu_);
  // The actuators whose bit is set in `devices` (all by default).
  std::vector<DeviceFailure> drive_safe_state_locked(const std::string& why,
                                                     uint32_t devices = UINT32_MAX) REQUIRES(mu_);

  Decider* decider_ GUARDED_BY(mu_);  // reload swaps it
  AuditLog& audit_;
  Clock& clock_;
  mutable base::Mutex mu_;
  std::map<uint8_t, bus::Bus*> buses_ GUARDED_BY(mu_);
  NameTable names_ GUARDED_BY(mu_);
  std::vector<uint32_t> task_devices_ GUARDED_BY(mu_);
  std::vector<core::Verdict> verdicts_
      GUARDED_BY(mu_);  // transfer()'s: reused, not allocated per call
  std::vector<gate::PlannedTx> planned_ GUARDED_BY(mu_);  // transfer()'s plan: reused the same way
  uint64_t retry_cap_us_ GUARDED_BY(mu_) = 0;  // the acting task's period (monitor.cc, try_by)
  readings::SensorReadings readings_ GUARDED_BY(mu_);
  uint16_t checking_task_ GUARDED_BY(mu_) = core::kNoTask;  // whose command the core is judging
  uint64_t checking_now_us_ GUARDED_BY(mu_) = 0;
  uint64_t check_seq_ GUARDED_BY(mu_) = 0;          // core checks so far (the records' `tx`)
  bool complain_now_ GUARDED_BY(mu_) = false;       // the transfer being checked complains
  std::string readings_json_ GUARDED_BY(mu_);       // describe_readings_locked()'s
  uint64_t readings_json_seq_ GUARDED_BY(mu_) = 0;  // the check readings_json_ is of (0: none)
  ComplainScope complain_ GUARDED_BY(mu_);
  std::map<uint16_t, uint64_t> job_phase_us_ GUARDED_BY(mu_);  // the release of each task's job 1
  TaskFacts facts_ GUARDED_BY(mu_);
  std::atomic<uint32_t> budget_factor_{0};  // read without mu_ when off
  std::map<uint16_t, Budget> budgets_ GUARDED_BY(mu_);
  std::atomic<uint64_t> holds_{0};
  DropReport drops_ GUARDED_BY(mu_);
  std::atomic<uint64_t> decisions_{0};
  std::atomic<uint64_t> audit_refusals_{0};
  bool audit_lost_ GUARDED_BY(mu_) = false;  // the last check()'s record was not written
  std::map<uint16_t, uint64_t> sample_due_us_
      GUARDED_BY(mu_);                                       // each periodic sensor's next sample
  std::map<uint16_t, uint64_t> safe_at_us_ GUARDED_BY(mu_);  // each actuator's last safe state
  // What deciding a transfer cost (check_transfer: the core's checks, not the
  // bus), as a histogram for the metrics: counts per upper bound in
  // kCheckCostBoundsNs (the last: above every bound), their sum and count.
  CheckCost check_cost_ GUARDED_BY(mu_);
  std::thread sampler_;
  std::condition_variable sampler_cv_;
  bool sampler_stop_ GUARDED_BY(mu_) = false;
};

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_MONITOR_H_
