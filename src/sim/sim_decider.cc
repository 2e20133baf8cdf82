#include "sim/sim_decider.h"

#include <cstring>

namespace contego::sim {
namespace {

// Protection off: the request as sent.
void pass(const core::Transaction& tx, core::Verdict* v) {
  const uint16_t device = v->device;
  *v = core::Verdict{};
  v->decision = core::Decision::kAllow;
  v->reason = tx.kind == core::TxKind::kWrite ? core::Reason::kAllowed : core::Reason::kReadAllowed;
  v->device = device;
  v->bus = tx.bus;
  v->addr = tx.addr;
  if (tx.kind == core::TxKind::kWrite && tx.len <= core::kMaxEmitBytes) {
    v->emit_count = 1;
    v->emit_len[0] = static_cast<uint16_t>(tx.len);
    v->emit_bytes_used = static_cast<uint16_t>(tx.len);
    std::memcpy(v->emit_bytes, tx.bytes, tx.len);
  }
}

}  // namespace

Status SimDecider::load(const PolicyImage& image) {
  const core::LoadResult lr =
      core_.checker().load(image.bytes.data(), static_cast<uint32_t>(image.bytes.size()));
  if (lr.status != core::LoadStatus::kOk) {
    return make_error(std::string("the checker refused the policy image: ") +
                      core::load_status_name(lr.status) + " (section " +
                      std::to_string(lr.section) + ", record " + std::to_string(lr.index) + ")");
  }
  return {};
}

SimDecider::Last SimDecider::last() const {
  std::lock_guard lock(mu_);
  return last_;
}

RunStats SimDecider::stats() const {
  std::lock_guard lock(mu_);
  return stats_;
}

void SimDecider::check(const core::Transaction& tx, core::Verdict* v) {
  core_.check(tx, v);
  std::lock_guard lock(mu_);
  last_.violation = v->decision != core::Decision::kAllow;
  if (!enforce_) pass(tx, v);
  last_.decision = v->decision;
  last_.reason = v->reason;
  const bool write = tx.kind == core::TxKind::kWrite;
  stats_.count(write, v->decision, write && last_.violation,
               tx.now_us > t0_us_ ? tx.now_us - t0_us_ : 0);
}

}  // namespace contego::sim
