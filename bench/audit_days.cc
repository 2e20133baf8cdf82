// Days of audit (issue 40): the rover's follower at its rate (3 commands per
// 200 ms: 15 decisions a second) for DAYS simulated days, through the real
// monitor and core on a virtual bus, in virtual time (a ManualClock: the job
// grid, the samples and the readings' ages advance as on the robot; the run
// itself is as fast as the writer). The audit log rotates at --max-bytes as
// `contego monitor --audit-max-bytes` does. Prints bytes per decision and
// per day, rotations, the cost of a checked and recorded transfer (mean, p99,
// worst, and the worst of those that rotated the file), and the largest rate
// one writer sustains; leaves the files for `contego audit` (bench/audit_days.sh).
//
// Usage: audit_days DIR [DAYS (default 1)] [MAX_BYTES (default 100 MB)] [RECORDS (0: DAYS' worth)]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fmt/core.h>
#include <memory>
#include <string>
#include <sys/stat.h>
#include <vector>

#include "base/clock.h"
#include "bus/virtual_bus.h"
#include "image/image_model.h"
#include "monitor/core_decider.h"
#include "monitor/monitor.h"
#include "policy/compile.h"

namespace contego {
namespace {

constexpr uint64_t kRatePerSecond = 15;  // the rover: 3 commands per 200 ms

uint64_t file_size(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0;
}

int run(int argc, char** argv) {
  if (argc < 2) {
    fmt::print(stderr, "usage: audit_days DIR [DAYS] [MAX_BYTES] [RECORDS]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const double days = argc > 2 ? std::atof(argv[2]) : 1.0;
  const uint64_t max_bytes = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 100u << 20;
  uint64_t records = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 0;
  if (records == 0) records = static_cast<uint64_t>(days * 86400.0 * kRatePerSecond);

  const policy::CompileOutput out = policy::compile_file(CONTEGO_SOURCE_POLICIES "/rover.policy");
  auto model =
      out.ok ? image::deserialize(out.image) : Result<image::ImageModel>(make_error("compile"));
  monitor::CoreDecider decider;
  if (!model.ok() ||
      decider.checker().load(out.image.data(), static_cast<uint32_t>(out.image.size())).status !=
          core::LoadStatus::kOk) {
    fmt::print(stderr, "audit_days: rover.policy does not load\n");
    return 1;
  }
  monitor::AuditOptions options;
  options.max_bytes = max_bytes;
  options.keep = 100000;  // every file of the run stays, for `contego audit`
  auto audit = std::make_unique<monitor::AuditLog>();
  const std::string path = dir + "/audit.jsonl";
  if (Status s = audit->open(path, options); !s.ok()) {
    fmt::print(stderr, "audit_days: {}\n", s.error());
    return 1;
  }
  bus::VirtualBus bus;
  bus.attach(std::make_shared<bus::GoPiGo2>(0x08));
  auto line = std::make_shared<bus::LineFollower>(0x06);
  line->set_values({767, 815, 1015, 710, 700});  // centred: every frame is allowed
  bus.attach(line);
  ManualClock clock(1'000'000);
  auto mon = std::make_unique<monitor::Monitor>(decider, *audit, clock);
  mon->set_names(monitor::name_table(*model));
  mon->add_bus(1, &bus);
  mon->set_drop_report(nullptr);
  mon->sample_all();
  const uint16_t follower = 0;
  // set_speed(80) as the vendor's loop sends it: left, right, then forward.
  const std::vector<std::vector<uint8_t>> frames = {
      {1, 70, 80, 0, 0}, {1, 71, 80, 0, 0}, {1, 105, 0, 0, 0}};
  std::vector<uint32_t> ns;
  ns.reserve(records);
  uint64_t worst_rotation_ns = 0, rotations = 0, failed = 0, last_position = 0;
  const uint64_t started = monotonic_ns();
  for (uint64_t i = 0; i < records; ++i) {
    clock.set_us(1'000'000 + i * 1'000'000 / kRatePerSecond);
    mon->sample_due();
    gate::Transfer t;
    t.bus = 1;
    gate::Message m;
    m.addr = 0x08;
    m.data = frames[i % frames.size()];
    m.len = static_cast<uint16_t>(m.data.size());
    t.messages.push_back(std::move(m));
    const uint64_t t0 = monotonic_ns();
    if (mon->transfer(follower, t).err != 0) ++failed;
    const uint64_t took = monotonic_ns() - t0;
    ns.push_back(static_cast<uint32_t>(std::min<uint64_t>(took, UINT32_MAX)));
    const uint64_t position = audit->position();
    if (position < last_position) {
      ++rotations;
      worst_rotation_ns = std::max(worst_rotation_ns, took);
    }
    last_position = position;
  }
  const double wall_s = static_cast<double>(monotonic_ns() - started) / 1e9;
  const monitor::DecisionCounts counts = mon->decision_counts(follower);
  mon.reset();
  audit.reset();  // the file closed: its preallocated tail cut
  uint64_t bytes = file_size(path);
  unsigned files = 1;
  for (unsigned k = 1; file_size(path + "." + std::to_string(k)) != 0; ++k, ++files) {
    bytes += file_size(path + "." + std::to_string(k));
  }
  std::vector<uint32_t> sorted = ns;
  std::sort(sorted.begin(), sorted.end());
  auto pct = [&](double p) {
    return sorted.empty()
               ? 0u
               : sorted[std::min(sorted.size() - 1,
                                 static_cast<size_t>(p * static_cast<double>(sorted.size())))];
  };
  uint64_t sum = 0;
  for (uint32_t v : ns) sum += v;
  const double mean_ns =
      ns.empty() ? 0.0 : static_cast<double>(sum) / static_cast<double>(ns.size());
  const double simulated_days =
      static_cast<double>(records) / static_cast<double>(kRatePerSecond) / 86400.0;
  const double per_decision = static_cast<double>(bytes) / static_cast<double>(records);
  fmt::print(
      "audit days: {:.2f} simulated day(s) of the rover's follower at {} decisions/s: "
      "{} transfers ({} allowed, {} failed), rover.policy, rotation at {} bytes\n",
      simulated_days, kRatePerSecond, records, counts.allowed, failed, max_bytes);
  fmt::print("  bytes per decision     {:.0f}\n", per_decision);
  fmt::print("  bytes per day, 1 task  {:.1f} MB ({:.2f} GB a week)\n",
             per_decision * kRatePerSecond * 86400.0 / 1e6,
             per_decision * kRatePerSecond * 86400.0 * 7.0 / 1e9);
  fmt::print("  files                  {} ({} rotations), {:.1f} MB in all\n", files, rotations,
             static_cast<double>(bytes) / 1e6);
  fmt::print("  checked + recorded     mean {:.2f} us, p50 {:.2f}, p99 {:.2f}, worst {:.1f} us\n",
             mean_ns / 1e3, pct(0.50) / 1e3, pct(0.99) / 1e3,
             sorted.empty() ? 0.0 : sorted.back() / 1e3);
  fmt::print("  a transfer that rotated  worst {:.1f} us\n",
             static_cast<double>(worst_rotation_ns) / 1e3);
  fmt::print("  one writer sustains    {:.0f} decisions/s (1 / mean; the rover needs {})\n",
             mean_ns > 0 ? 1e9 / mean_ns : 0.0, kRatePerSecond);
  fmt::print("  run time               {:.1f} s\n", wall_s);
  return failed == 0 ? 0 : 1;
}

}  // namespace
}  // namespace contego

int main(int argc, char** argv) { return contego::run(argc, argv); }
