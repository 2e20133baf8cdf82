// The pieces a simulated scenario is made of: controllers (periodic tasks
// that talk to devices only through a Port, with the bytes the vendor
// libraries send), attacks (logic bombs that rewrite a job's bus operations
// while active), and a World (the plant, its device models and its
// measurements).
//
// Time is virtual, in integer microseconds; nothing here reads a clock.
#ifndef CONTEGO_SIM_WORLD_H_
#define CONTEGO_SIM_WORLD_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "base/result.h"
#include "bus/virtual_bus.h"
#include "sim/noise.h"

namespace contego::sim {

// One bus operation as a task issues it (bus i2c-1 throughout).
struct BusOp {
  enum class Kind : uint8_t { kWrite, kRead };
  Kind kind = Kind::kWrite;
  uint16_t addr = 0;
  std::vector<uint8_t> bytes;  // write: the bytes after the address
  uint32_t read_len = 0;       // read: bytes to read
};

BusOp write_op(uint16_t addr, std::vector<uint8_t> bytes);
BusOp read_op(uint16_t addr, uint32_t len);

// A write a job schedules at an absolute virtual time.
struct TimedOp {
  uint64_t at_us = 0;
  std::string task;  // the policy's task name of the sender
  BusOp op;
  bool injected = false;  // added or rewritten by an attack (for the event log)

  // A write of `of_task` of `len` bytes to the device at `to_addr`.
  bool is_write(const std::string& of_task, uint16_t to_addr, size_t len) const {
    return task == of_task && op.kind == BusOp::Kind::kWrite && op.addr == to_addr &&
           op.bytes.size() == len;
  }
  // For a one-register write [reg, byte] of the low (`reg`) or the high
  // (`reg + 1`) byte of a 16-bit register pair: puts that byte of `value` in
  // it. True if the write was one of the two.
  bool rewrite_word(uint8_t reg, uint16_t value) {
    if (op.bytes[0] == reg) {
      op.bytes[1] = static_cast<uint8_t>(value & 0xFF);
      return true;
    }
    if (op.bytes[0] == reg + 1) {
      op.bytes[1] = static_cast<uint8_t>(value >> 8);
      return true;
    }
    return false;
  }
};

// What a task sees of the bus: reads and writes go through the guard.
class Port {
 public:
  virtual ~Port() = default;
  // Performs a write now on behalf of `task`; true if the client call succeeded
  // (an IGNORE also reports success, as the paper's checker does).
  virtual bool write(const std::string& task, const BusOp& op) = 0;
  // Performs a read now; nullopt if the read was refused.
  virtual std::optional<std::vector<uint8_t>> read(const std::string& task, const BusOp& op) = 0;
};

struct Job {
  uint64_t index = 0;       // 1-based job number of the task
  uint64_t release_us = 0;  // release time
};

// A periodic control task: the policy's task name of its bus operations, its
// period, and the release time of its first job.
class Controller {
 public:
  Controller(std::string task, uint64_t period_us, uint64_t offset_us = 0)
      : task_(std::move(task)), period_us_(period_us), offset_us_(offset_us) {}
  virtual ~Controller() = default;
  const std::string& task() const { return task_; }
  uint64_t period_us() const { return period_us_; }
  uint64_t offset_us() const { return offset_us_; }
  // Runs the job's computation at its release: reads go through `port`
  // immediately, writes are appended to `ops` with their times.
  virtual void release(const Job& job, Port& port, std::vector<TimedOp>& ops) = 0;

 protected:
  // Reads `len` bytes from register `reg` of the device at `addr` now (the
  // register pointer, then the read, in one combined transfer).
  std::optional<std::vector<uint8_t>> read_register(Port& port, uint16_t addr, uint8_t reg,
                                                    uint32_t len) const {
    BusOp op = read_op(addr, len);
    op.bytes = {reg};
    return port.read(task_, op);
  }
  // Reads `count` big-endian 16-bit words from register `reg` on (as above);
  // nullopt if the read was refused or came back short.
  std::optional<std::vector<uint16_t>> read_words(Port& port, uint16_t addr, uint8_t reg,
                                                  uint32_t count) const {
    auto r = read_register(port, addr, reg, 2 * count);
    if (!r || r->size() < 2 * size_t{count}) return std::nullopt;
    std::vector<uint16_t> words(count);
    for (uint32_t i = 0; i < count; ++i) {
      words[i] = static_cast<uint16_t>(((*r)[2 * i] << 8) | (*r)[2 * i + 1]);
    }
    return words;
  }
  // Schedules a write of this task at `at_us`.
  void schedule(std::vector<TimedOp>& ops, uint64_t at_us, uint16_t addr,
                std::vector<uint8_t> bytes) const {
    ops.push_back({at_us, task_, write_op(addr, std::move(bytes))});
  }
  // Schedules a 16-bit value as two one-register writes, the low byte to
  // `reg` and the high byte to `reg + 1` (for devices that do not
  // auto-increment their register pointer).
  void schedule_word(std::vector<TimedOp>& ops, uint64_t at_us, uint16_t addr, uint8_t reg,
                     uint16_t value) const {
    schedule(ops, at_us, addr, {reg, static_cast<uint8_t>(value & 0xFF)});
    schedule(ops, at_us, addr, {static_cast<uint8_t>(reg + 1), static_cast<uint8_t>(value >> 8)});
  }

 private:
  std::string task_;
  uint64_t period_us_;
  uint64_t offset_us_;
};

// An attack definition from a scenario file.
struct AttackSpec {
  std::string kind;  // "spoof", "dos", ...
  uint64_t start_us = 0;
  uint64_t end_us = 0;
  std::map<std::string, std::string> params;

  bool active(uint64_t t) const { return t >= start_us && t < end_us; }
  int64_t param_int(const std::string& key, int64_t fallback) const;
};

// A logic bomb inside (or beside) a controller: rewrites a job's operations
// while the job's release time lies in its window.
class Attack {
 public:
  // `victim`: the task whose jobs the attack rewrites (empty: any task's).
  explicit Attack(AttackSpec spec, std::string victim = {})
      : spec_(std::move(spec)), victim_(std::move(victim)) {}
  virtual ~Attack() = default;
  const AttackSpec& spec() const { return spec_; }
  virtual void apply(const Job& job, const std::string& task, std::vector<TimedOp>& ops,
                     Noise& noise) = 0;

 protected:
  // The window is open at the job's release and `task` is the victim.
  bool hits(const Job& job, const std::string& task) const {
    return spec_.active(job.release_us) && (victim_.empty() || task == victim_);
  }

 private:
  AttackSpec spec_;
  std::string victim_;
};

// A device-side event worth plotting (e.g. every pulse the gripper channel
// received, in order).
struct Event {
  uint64_t time_us;
  std::string what;
  double value;
};

struct Metric {
  std::string name;  // "distance", "objects_handled" ...
  double value;
  std::string unit;  // "cm", "", "mL" ...
};

// A plant with its device models, controllers and measurements. A plant
// registers in its constructor what it is made of (device models,
// controllers, trace columns, attacks) and overrides only its physics and
// measurements.
class World {
 public:
  World(const World&) = delete;
  World& operator=(const World&) = delete;
  virtual ~World() = default;
  // Puts the world's device models on `bus`.
  void attach(bus::VirtualBus& bus) const;
  // Called after a write reached the bus (a logic-analyser tap): lets the
  // world log what the devices actually received.
  virtual void on_write(uint64_t /*now_us*/, uint16_t /*addr*/,
                        std::span<const uint8_t> /*bytes*/) {}
  const std::vector<Controller*>& controllers() const { return controllers_; }
  // Builds the attack of `spec`, or says which kinds this world knows.
  Result<std::unique_ptr<Attack>> make_attack(const AttackSpec& spec) const;
  // Advances the physics by `dt_us` ending at `now_us` and refreshes the
  // sensor device models.
  virtual void step(uint64_t now_us, uint64_t dt_us) = 0;
  // Trace columns (after time) and their current values.
  const std::vector<std::string>& columns() const { return columns_; }
  std::vector<double> sample() const;
  std::vector<Metric> metrics() const;
  const std::vector<Event>& events() const { return events_; }

 protected:
  // `name`: the plant in messages ("rover"); `noise_seed`: the seed of the
  // plant's noise stream.
  World(std::string name, uint64_t noise_seed) : noise_(noise_seed), name_(std::move(name)) {}

  // Registers a device model (attached in registration order) and returns it.
  template <typename Device>
  std::shared_ptr<Device> add_device(std::shared_ptr<Device> device) {
    devices_.push_back(device);
    return device;
  }
  void set_controllers(std::vector<Controller*> controllers) {
    controllers_ = std::move(controllers);
  }
  // A measurement of the plant's current state.
  using Probe = std::function<double()>;
  // Adds a trace column (in registration order) and what it samples.
  void add_column(std::string name, Probe value) {
    columns_.push_back(std::move(name));
    column_values_.push_back(std::move(value));
  }
  // Adds a metric of the run (reported in registration order).
  void add_metric(std::string name, std::string unit, Probe value) {
    metrics_.push_back({std::move(name), std::move(unit), std::move(value)});
  }
  using AttackMaker = std::function<std::unique_ptr<Attack>(const AttackSpec&)>;
  // Registers the attack `kind` (listed in messages in registration order).
  void add_attack(std::string kind, AttackMaker make) {
    attacks_.emplace_back(std::move(kind), std::move(make));
  }

  Noise noise_;
  std::vector<Event> events_;

 private:
  std::string name_;
  std::vector<std::string> columns_;
  std::vector<Probe> column_values_;
  struct MetricProbe {
    std::string name, unit;
    Probe value;
  };
  std::vector<MetricProbe> metrics_;
  std::vector<std::shared_ptr<bus::DeviceModel>> devices_;
  std::vector<Controller*> controllers_;
  std::vector<std::pair<std::string, AttackMaker>> attacks_;
};

}  // namespace contego::sim

#endif  // CONTEGO_SIM_WORLD_H_
