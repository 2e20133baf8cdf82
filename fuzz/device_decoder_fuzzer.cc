// Fuzzes the core's device decoders: random bus writes go through a Checker
// loaded with an image holding all three built-in profiles and a generic
// register map, lowered by devices::append_device. Besides crashes it checks
//  - that the lowered image passes the core's verifier,
//  - that every verdict is well formed (emit lengths add up, within limits),
//  - differentially, that the core allows a write exactly when the host
//    reference decoder (devices::HostDecoder) decodes it into commands none of
//    which is forbidden. The policy allows everything else (full access, no
//    rules), so any disagreement is a decoding difference (except writes
//    beyond the core's per-transaction capacity). The host mirrors follow
//    only writes to a device's own address; once the core lets a write
//    through another address (the PCA9685 all-call, say) the mirrors may no
//    longer match the core's registers, and the comparison stops there.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "contego/core/checker.h"

#include "core/test_fixtures.h"
#include "devices/codec.h"
#include "devices/lower.h"
#include "image/image_model.h"

namespace {

using namespace contego;

struct Fixture {
  image::ImageModel model;
  std::vector<uint8_t> image;
  std::vector<devices::ProfileSpec> profiles;  // per device id
};

[[noreturn]] void die(const char* what) {
  std::fprintf(stderr, "device_decoder_fuzzer: %s\n", what);
  std::abort();
}

const Fixture& fixture() {
  static const Fixture kFixture = [] {
    Fixture f;
    devices::RegmapDecl valve;
    valve.name = "valve";
    valve.auto_increment = true;
    valve.registers = {{"level", 0x01, 1, false, false, 0, 100, ""},
                       {"flow", 0x02, 2, true, false, 0, 4000, ""}};
    valve.forbidden = {{0x10, 0xFF}};
    auto regmap = devices::make_regmap_profile(valve);
    if (!regmap) die(regmap.error().c_str());
    struct Entry {
      devices::ProfileSpec profile;
      uint16_t addr;
    };
    const std::vector<Entry> entries = {{*devices::find_builtin_profile("gopigo2"), 0x08},
                                        {*devices::find_builtin_profile("line_follower"), 0x06},
                                        {*devices::find_builtin_profile("pca9685"), 0x40},
                                        {*regmap, 0x20}};
    for (const Entry& e : entries) {
      devices::DeviceBinding b;
      b.name = e.profile.name;
      b.bus = 1;
      b.addr = e.addr;
      b.sample_period_us = 10000;
      b.max_sample_age_us = 100000;
      auto id = devices::append_device(f.model, e.profile, b);
      if (!id) die(id.error().c_str());
      f.profiles.push_back(e.profile);
    }
    f.model.tasks.push_back(core::testing::task_rec("t", 100000, 1000, 1, 1));
    core::AccessRecord access{};
    access.actuate_devices = 0xF;
    access.read_devices = 0xF;
    f.model.access.push_back(access);
    f.image = image::serialize(f.model);
    return f;
  }();
  return kFixture;
}

constexpr uint16_t kAddrs[] = {0x08, 0x06, 0x40, 0x70, 0x00, 0x20, 0x41, 0x08};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const Fixture& f = fixture();
  auto checker = std::make_unique<core::Checker>();
  const core::LoadResult lr = checker->load(f.image.data(), static_cast<uint32_t>(f.image.size()));
  if (lr.status != core::LoadStatus::kOk) die(core::load_status_name(lr.status));
  std::vector<devices::HostDecoder> mirrors;
  for (const auto& p : f.profiles) mirrors.emplace_back(p);

  // Input: a sequence of [header, len, bytes...]; header bits 0-2 pick the
  // address, bit 3 the task (declared / unknown), bits 4-5 the kind.
  size_t pos = 0;
  uint64_t now = 0;
  bool mirrors_in_step = true;
  while (pos + 2 <= size) {
    const uint8_t header = data[pos];
    const size_t len = std::min<size_t>(data[pos + 1] % 70, size - pos - 2);
    const uint8_t* bytes = data + pos + 2;
    pos += 2 + len;
    core::Transaction tx{};
    tx.task = (header & 8) != 0 ? core::kNoTask : 0;
    tx.bus = 1;
    tx.kind = (header >> 4) % 3 == 0   ? core::TxKind::kRead
              : (header >> 4) % 3 == 1 ? core::TxKind::kQuick
                                       : core::TxKind::kWrite;
    if ((header >> 4) >= 3) tx.kind = core::TxKind::kWrite;
    tx.addr = kAddrs[header & 7];
    tx.job = 1;
    tx.len = static_cast<uint32_t>(len);
    tx.bytes = bytes;
    tx.now_us = now += 1000;
    core::Verdict v{};
    checker->check(tx, &v);

    if (v.emit_count > core::kMaxEmits || v.emit_bytes_used > core::kMaxEmitBytes) {
      die("verdict emits beyond limits");
    }
    uint32_t total = 0;
    for (uint32_t k = 0; k < v.emit_count; ++k) total += v.emit_len[k];
    if (total != v.emit_bytes_used) die("emit lengths do not add up");
    if (static_cast<uint8_t>(v.decision) > 3) die("unknown decision");
    if (tx.task == core::kNoTask && tx.kind == core::TxKind::kWrite &&
        v.decision == core::Decision::kAllow) {
      die("a write from an unknown task was allowed");
    }

    // Differential check on plain writes from the declared task to a device's
    // own address (aliases and general call are the core's business).
    int device = -1;
    for (int d = 0; d < 4; ++d) {
      if (f.model.devices[d].record.addr == tx.addr) device = d;
    }
    if (device < 0 && tx.kind == core::TxKind::kWrite &&
        (v.decision == core::Decision::kAllow || v.decision == core::Decision::kFailsafe)) {
      mirrors_in_step = false;  // an alias write may have changed registers
    }
    if (tx.kind != core::TxKind::kWrite || tx.task != 0 || device < 0 || len == 0 ||
        !mirrors_in_step) {
      continue;
    }
    devices::HostDecoder before = mirrors[device];
    auto decoded = mirrors[device].write(std::span<const uint8_t>(bytes, len));
    bool host_allows = decoded.ok();
    if (decoded.ok()) {
      for (const auto& c : *decoded) {
        if (c.command->command_class == core::CommandClass::kForbidden) host_allows = false;
        // Queries to a pure sensor are allowed with read access as well.
      }
    }
    const bool core_allows = v.decision == core::Decision::kAllow;
    // A write that completes many commands may exceed the core's per-
    // transaction capacity (commands, emitted bytes); it then refuses the
    // whole write as too long, which is the documented fail-closed answer.
    const bool capacity = !core_allows && v.reason == core::Reason::kTooLong &&
                          (len > core::kMaxWriteBytes || (decoded.ok() && decoded->size() > 1));
    // A gated command the device would not take now (PCA9685 PRE_SCALE while
    // MODE1 SLEEP is clear): the core answers `not-taken` from its shadow;
    // the host decoder does not model the gate (the mirror is restored below).
    const bool not_taken = !core_allows && v.reason == core::Reason::kNotTaken;
    if (host_allows != core_allows && !capacity && !not_taken) {
      std::fprintf(stderr, "device %d write of %zu bytes: host %s (%s), core %s (%s)\n", device,
                   len, host_allows ? "allows" : "refuses",
                   decoded.ok() ? "decoded" : decoded.error().c_str(),
                   core::decision_name(v.decision), core::reason_name(v.reason));
      for (size_t i = 0; i < len; ++i) std::fprintf(stderr, " %02x", bytes[i]);
      std::fprintf(stderr, "\n");
      die("core and host decoder disagree");
    }
    if (!core_allows) mirrors[device] = before;  // nothing reached the device
  }
  return 0;
}
