// Fuzzes the trusted core's image verifier: any byte string goes to
// Checker::load(). Besides crashes (ASan/UBSan), it checks that an accepted
// image is usable: a handful of transactions of every kind are checked and
// every verdict must be well formed (emit lengths add up, within limits).
// Seeds: valid rover and arm images (fuzz/corpus/image_verifier/).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "contego/core/checker.h"

#include "core/internal.h"

namespace {

using namespace contego::core;

uint32_t read_sample(void*, uint16_t device, uint8_t* buf, uint32_t capacity, uint64_t* taken) {
  // A sample that changes with the device, long enough for any declared field.
  const uint32_t n = capacity < kMaxSampleBytes ? capacity : kMaxSampleBytes;
  for (uint32_t i = 0; i < n; ++i) buf[i] = static_cast<uint8_t>(device * 31 + i * 7);
  *taken = 1000;
  return n;
}

void check_well_formed(const Verdict& v) {
  uint32_t total = 0;
  for (uint32_t i = 0; i < v.emit_count; ++i) total += v.emit_len[i];
  if (v.emit_count > kMaxEmits || total != v.emit_bytes_used || total > kMaxEmitBytes ||
      static_cast<uint8_t>(v.decision) > 3 ||
      ((v.decision == Decision::kReject || v.decision == Decision::kIgnore) && v.emit_count != 0)) {
    std::fprintf(stderr, "malformed verdict: decision %u emits %u bytes %u/%u\n",
                 static_cast<unsigned>(v.decision), v.emit_count, total, v.emit_bytes_used);
    std::abort();
  }
}

}  // namespace

void fuzz_one(const uint8_t* data, size_t size);

// Each input is tried as is and with its checksum recomputed, so mutations
// reach the structural checks behind the CRC.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > kMaxImageBytes) return 0;
  fuzz_one(data, size);
  if (size >= 16) {
    std::unique_ptr<uint8_t[]> copy(new uint8_t[size]);
    std::memcpy(copy.get(), data, size);
    const uint32_t crc = contego::core::internal::crc32(copy.get() + 16, size - 16);
    std::memcpy(copy.get() + 12, &crc, 4);
    fuzz_one(copy.get(), size);
  }
  return 0;
}

void fuzz_one(const uint8_t* data, size_t size) {
  static Checker* checker = new Checker();  // ~200 KiB: not on the stack
  const LoadResult r = checker->load(data, static_cast<uint32_t>(size));
  if (r.status != LoadStatus::kOk) {
    if (checker->loaded()) std::abort();  // a refused image must leave nothing loaded
    return;
  }
  Host host{};
  host.read_sample = read_sample;
  checker->set_host(host);
  // Probe every device and task with a few writes, a read and a safe state.
  static const uint8_t kWrites[][6] = {{1, 119, 0, 0, 0, 0},        {119, 0, 0, 0, 0, 0},
                                       {0x06, 0, 0, 0x77, 0x01, 0}, {0x00, 0x21, 0, 0, 0, 0},
                                       {0xFF, 1, 2, 3, 4, 5},       {70, 200, 0, 0, 0, 0}};
  uint64_t now = 0;
  for (uint16_t dev = 0; dev < checker->device_count(); ++dev) {
    const DeviceRecord& d = checker->device(dev);
    for (uint16_t task = 0; task < checker->task_count() && task < 4; ++task) {
      for (uint32_t w = 0; w < sizeof(kWrites) / sizeof(kWrites[0]); ++w) {
        for (uint32_t len : {2u, 4u, 5u, 6u}) {
          Transaction tx{task, d.bus, TxKind::kWrite, d.addr,     d.ten_bit, 0,
                         0,    len,   kWrites[w],     now += 1000};
          Verdict v{};
          checker->check(tx, &v);
          check_well_formed(v);
        }
      }
      Transaction rd{task, d.bus, TxKind::kRead, d.addr, d.ten_bit, 0, 0, 0, nullptr, now};
      Verdict v{};
      checker->check(rd, &v);
      check_well_formed(v);
    }
    Verdict safe{};
    if (checker->safe_state(dev, &safe)) check_well_formed(safe);
    checker->reset_latch(dev);
  }
}
