#include "sim/monitor_guard.h"

#include "gate/transfer.h"

namespace contego::sim {

int RecordingBus::transfer(std::span<bus::Msg> msgs) {
  const int err = bus_.transfer(msgs);
  if (err == 0 && recording && msgs.size() == 1 && (msgs[0].flags & gate::kMsgRead) == 0) {
    written_addr = msgs[0].addr;
    written.emplace_back(msgs[0].buf, msgs[0].buf + msgs[0].len);
  }
  return err;
}

MonitorGuard::MonitorGuard(bus::Bus& bus, std::vector<std::string> task_names, bool observe)
    : task_names_(std::move(task_names)), observe_(observe), bus_(bus), decider_(!observe) {}

Result<std::unique_ptr<MonitorGuard>> MonitorGuard::create(const PolicyImage& image, bus::Bus& bus,
                                                           bool observe) {
  std::unique_ptr<MonitorGuard> g(new MonitorGuard(bus, image.task_names, observe));
  if (Status st = g->decider_.load(image); !st) return make_error(st.error());
  g->monitor_ = std::make_unique<monitor::Monitor>(g->decider_, g->audit_, g->clock_);
  g->monitor_->add_bus(1, &g->bus_);
  g->monitor_->set_names(image.names);
  if (observe) g->monitor_->set_drop_report(nullptr);  // nothing is dropped: no drop lines
  g->monitor_->set_task_names(image.task_names);
  return g;
}

uint16_t MonitorGuard::task_id(const std::string& name) const {
  for (size_t i = 0; i < task_names_.size(); ++i) {
    if (task_names_[i] == name) return static_cast<uint16_t>(i);
  }
  return core::kNoTask;
}

void MonitorGuard::tick(uint64_t now_us) {
  clock_.set_us(now_us);
  (void)monitor_->sample_due();
}

void MonitorGuard::released(const std::string& task, uint64_t now_us) {
  clock_.set_us(now_us);
  monitor_->job_boundary(task_id(task));
}

GuardResult MonitorGuard::perform(const std::string& task, const BusOp& op, uint64_t now_us) {
  clock_.set_us(now_us);
  // The operation as a task's I2C_RDWR: one write message, or a read preceded
  // by its register pointer in the same combined transfer.
  gate::Transfer t;
  t.bus = 1;
  const bool write = op.kind == BusOp::Kind::kWrite;
  if (write || !op.bytes.empty()) {
    t.messages.push_back({op.addr, 0, static_cast<uint16_t>(op.bytes.size()), op.bytes});
  }
  if (!write) {
    t.messages.push_back({op.addr, gate::kMsgRead, static_cast<uint16_t>(op.read_len), {}});
  }
  bus_.recording = true;
  bus_.written.clear();
  gate::TransferReply reply = monitor_->transfer(task_id(task), t);
  bus_.recording = false;

  const SimDecider::Last last = decider_.last();
  GuardResult r;
  r.violation = last.violation;
  r.addr = bus_.written.empty() ? op.addr : bus_.written_addr;
  if (!observe_) {  // observe mode reports every operation as allowed
    r.decision = last.decision;
    r.reason = last.reason;
  }
  r.emits = std::move(bus_.written);
  if (!write && reply.err == 0 && r.decision == core::Decision::kAllow && !reply.reads.empty()) {
    r.data = std::move(reply.reads.back());
  }
  return r;
}

}  // namespace contego::sim
