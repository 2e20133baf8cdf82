// Zero false positives: every scenario in scenarios/, attack-free, with its
// shipped policy and ten noise seeds, runs through the real checker without a
// single violation, substitution or latch; and its attack run is still
// stopped (every violation lies on an injected operation, or is the latch
// holding the device after the attack).
#include <algorithm>
#include <filesystem>
#include <gtest/gtest.h>
#include <string>
#include <vector>

#include "policy/compile.h"
#include "sim/monitor_guard.h"
#include "sim/runner.h"

namespace contego::sim {
namespace {

constexpr int kSeeds = 10;

std::vector<std::string> scenario_files() {
  std::vector<std::string> files;
  for (const auto& e :
       std::filesystem::directory_iterator(std::string(CONTEGO_SOURCE_DIR) + "/scenarios")) {
    if (e.is_regular_file() && e.path().extension() == ".scn") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string name_of(const ::testing::TestParamInfo<std::string>& info) {
  return std::filesystem::path(info.param).stem().string();
}

class EveryScenario : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    auto sc = load_scenario(GetParam());
    ASSERT_TRUE(sc.ok()) << sc.error();
    scenario_ = *sc;
    auto out = policy::compile_file(scenario_.policy_path);
    std::string diags;
    for (const auto& d : out.diagnostics) diags += d.rendered + "\n";
    ASSERT_TRUE(out.ok) << diags;
    image_.bytes = out.image;
    for (const auto& t : out.model.tasks) image_.task_names.push_back(t.name);
  }

  RunResult run(bool attacks, uint64_t seed) {
    GuardFactory guard = [this](bus::VirtualBus& bus) -> Result<std::unique_ptr<Guard>> {
      auto g = MonitorGuard::create(image_, bus, /*observe=*/false);
      if (!g) return make_error(g.error());
      return std::unique_ptr<Guard>(std::move(*g));
    };
    auto r = run_scenario(scenario_, {"protected", attacks, guard, seed});
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error());
    return r.ok() ? std::move(*r) : RunResult{};
  }

  Scenario scenario_;
  PolicyImage image_;
};

std::string first_violation(const RunResult& r) {
  for (const auto& op : r.ops) {
    if (!op.violation) continue;
    std::string bytes;
    for (uint8_t b : op.bytes) bytes += " " + std::to_string(b);
    return "t=" + std::to_string(op.time_us) + "us task " + op.task + " addr " +
           std::to_string(op.addr) + (op.read ? " read" : " write") + bytes + " reason " +
           std::to_string(static_cast<int>(op.reason));
  }
  return "none";
}

TEST_P(EveryScenario, AttackFreeRunHasNoViolationWithTenNoiseSeeds) {
  for (uint64_t seed = 1; seed <= kSeeds; ++seed) {
    const RunResult r = run(/*attacks=*/false, seed);
    EXPECT_EQ(r.stats.violations, 0u) << "seed " << seed << ", first: " << first_violation(r);
    EXPECT_EQ(r.stats.replaced, 0u) << "seed " << seed;
    EXPECT_EQ(r.stats.ignored, 0u) << "seed " << seed;
    EXPECT_EQ(r.stats.rejected, 0u) << "seed " << seed;
    const bool latched = std::any_of(r.ops.begin(), r.ops.end(), [](const OpRecord& op) {
      return op.reason == core::Reason::kLatched;
    });
    EXPECT_FALSE(latched) << "seed " << seed;
  }
}

TEST_P(EveryScenario, AttackRunIsStoppedAndOnlyTheAttackIsJudged) {
  ASSERT_FALSE(scenario_.attacks.empty());
  const RunResult r = run(/*attacks=*/true, scenario_.seed);
  uint64_t start = UINT64_MAX;
  for (const auto& a : scenario_.attacks) start = std::min(start, a.start_us);
  uint64_t injected = 0, injected_acted = 0;
  for (const auto& op : r.ops) {
    if (op.violation) {
      EXPECT_TRUE(op.injected || op.reason == core::Reason::kLatched)
          << "an honest operation judged a violation at " << op.time_us << "us (task " << op.task
          << ", reason " << static_cast<int>(op.reason) << ")";
      EXPECT_GE(op.time_us, start);
    }
    if (!op.injected || op.read) continue;
    ++injected;
    // An injected command that acted unchanged was one the policy allows.
    if (op.decision == core::Decision::kAllow && !op.violation) ++injected_acted;
  }
  EXPECT_GT(injected, 0u);
  RecordProperty("injected", static_cast<int>(injected));
  RecordProperty("injected_allowed", static_cast<int>(injected_acted));
}

INSTANTIATE_TEST_SUITE_P(Scenarios, EveryScenario, ::testing::ValuesIn(scenario_files()), name_of);

}  // namespace
}  // namespace contego::sim
