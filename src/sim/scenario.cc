#include "sim/scenario.h"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "base/read_file.h"
#include "sim/arm.h"
#include "sim/camera.h"
#include "sim/pump.h"
#include "sim/rover.h"
#include "sim/tank.h"

namespace contego::sim {
namespace {

std::vector<std::string> split_words(std::string_view line) {
  std::vector<std::string> words;
  std::istringstream in{std::string(line)};
  std::string w;
  while (in >> w) words.push_back(w);
  return words;
}

}  // namespace

const std::vector<std::string>& platforms() {
  static const std::vector<std::string> kPlatforms = {"rover", "arm", "tank", "pump", "camera"};
  return kPlatforms;
}

Result<Scenario> parse_scenario(std::string_view text, const std::string& file_name,
                                const std::string& base_dir) {
  Scenario sc;
  sc.name = std::filesystem::path(file_name).stem().string();
  std::set<std::string> seen;
  size_t line_no = 0;
  auto fail = [&](const std::string& msg) {
    return make_error(file_name + ":" + std::to_string(line_no) + ": " + msg);
  };
  std::istringstream in{std::string(text)};
  std::string raw;
  while (std::getline(in, raw)) {
    ++line_no;
    std::string_view line = raw;
    if (auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    auto words = split_words(line);
    if (words.empty()) continue;
    const std::string& key = words[0];
    const bool repeatable = key == "set" || key == "attack";
    if (!repeatable && !seen.insert(key).second) return fail("'" + key + "' given twice");
    auto need = [&](size_t n) { return words.size() == n; };
    if (key == "title") {
      auto pos = line.find("title") + 5;
      auto rest = line.substr(pos);
      while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
      while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\t' || rest.back() == '\r')) {
        rest.remove_suffix(1);
      }
      sc.title = std::string(rest);
    } else if (key == "platform") {
      if (!need(2)) return fail("expected 'platform NAME'");
      sc.platform = words[1];
      bool known = false;
      for (const auto& p : platforms()) known = known || p == sc.platform;
      if (!known) {
        std::string list;
        for (const auto& p : platforms()) list += (list.empty() ? "" : ", ") + p;
        return fail("unknown platform '" + sc.platform + "' (expected one of: " + list + ")");
      }
    } else if (key == "policy") {
      if (!need(2)) return fail("expected 'policy PATH'");
      std::filesystem::path p(words[1]);
      sc.policy_path =
          p.is_absolute() ? p.string() : (std::filesystem::path(base_dir) / p).string();
    } else if (key == "duration" || key == "step" || key == "trace") {
      if (!need(2)) return fail("expected '" + key + " DURATION' (e.g. 30s, 1ms)");
      auto d = parse_duration_us(words[1]);
      if (!d || *d == 0) {
        return fail("'" + words[1] + "' is not a positive duration with a unit (us, ms, s, min)");
      }
      (key == "duration" ? sc.duration_us : key == "step" ? sc.step_us : sc.trace_us) = *d;
    } else if (key == "seed") {
      auto v = need(2) ? parse_int(words[1]) : std::nullopt;
      if (!v || *v < 0) return fail("expected 'seed N' with N a non-negative integer");
      sc.seed = static_cast<uint64_t>(*v);
    } else if (key == "set") {
      if (!need(3)) return fail("expected 'set KEY VALUE'");
      if (!sc.settings.emplace(words[1], words[2]).second) {
        return fail("setting '" + words[1] + "' given twice");
      }
    } else if (key == "attack") {
      // attack KIND from START to END [key=value ...]
      if (words.size() < 6 || words[2] != "from" || words[4] != "to") {
        return fail("expected 'attack KIND from START to END [key=value ...]'");
      }
      AttackSpec a;
      a.kind = words[1];
      auto s = parse_duration_us(words[3]);
      auto e = parse_duration_us(words[5]);
      if (!s) return fail("attack start '" + words[3] + "' is not a duration with a unit");
      if (!e) return fail("attack end '" + words[5] + "' is not a duration with a unit");
      if (*e <= *s) return fail("attack window ends before it starts");
      a.start_us = *s;
      a.end_us = *e;
      for (size_t i = 6; i < words.size(); ++i) {
        auto eq = words[i].find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == words[i].size()) {
          return fail("attack parameter '" + words[i] + "' is not key=value");
        }
        a.params[words[i].substr(0, eq)] = words[i].substr(eq + 1);
      }
      sc.attacks.push_back(std::move(a));
    } else {
      return fail("unknown keyword '" + key +
                  "' (expected title, platform, policy, duration, step, trace, seed, set, attack)");
    }
  }
  line_no = 0;
  if (sc.platform.empty()) return make_error(file_name + ": missing 'platform' line");
  if (sc.policy_path.empty()) return make_error(file_name + ": missing 'policy' line");
  if (sc.step_us > sc.trace_us) return make_error(file_name + ": 'step' is longer than 'trace'");
  if (sc.trace_us % sc.step_us != 0) {
    return make_error(file_name + ": 'trace' must be a multiple of 'step'");
  }
  // Bounds, so a typo cannot make a run that allocates its trace until it
  // dies or steps for days: a million trace rows, a billion steps.
  if (sc.duration_us / sc.trace_us > kMaxTraceRows) {
    return make_error(file_name + ": 'duration' / 'trace' is more than " +
                      std::to_string(kMaxTraceRows) + " trace rows; expected a longer 'trace'");
  }
  if (sc.duration_us / sc.step_us > kMaxSteps) {
    return make_error(file_name + ": 'duration' / 'step' is more than " +
                      std::to_string(kMaxSteps) + " steps; expected a shorter 'duration'");
  }
  if (sc.attacks.empty()) return make_error(file_name + ": no 'attack' line");
  for (const auto& a : sc.attacks) {
    if (a.end_us > sc.duration_us) {
      return make_error(file_name + ": attack '" + a.kind + "' ends after the scenario's duration");
    }
  }
  if (sc.title.empty()) sc.title = sc.name;
  // Let the platform validate its settings-independent parts: attack kinds.
  auto world = make_world(sc, sc.seed);
  if (!world) return make_error(file_name + ": " + world.error());
  for (const auto& a : sc.attacks) {
    auto attack = (*world)->make_attack(a);
    if (!attack) return make_error(file_name + ": " + attack.error());
  }
  return sc;
}

Result<Scenario> load_scenario(const std::string& path) {
  Result<std::string> text = read_input_file(path);
  if (!text) return make_error("cannot read the scenario file " + text.error());
  auto dir = std::filesystem::path(path).parent_path().string();
  return parse_scenario(*text, path, dir.empty() ? "." : dir);
}

Result<std::unique_ptr<World>> make_world(const Scenario& scenario, uint64_t seed) {
  std::unique_ptr<World> w;
  if (scenario.platform == "rover") {
    w = std::make_unique<RoverWorld>(scenario.settings, seed);
  } else if (scenario.platform == "arm") {
    w = std::make_unique<ArmWorld>(scenario.settings, seed);
  } else if (scenario.platform == "tank") {
    w = std::make_unique<TankWorld>(scenario.settings, seed);
  } else if (scenario.platform == "pump") {
    w = std::make_unique<PumpWorld>(scenario.settings, seed);
  } else if (scenario.platform == "camera") {
    w = std::make_unique<CameraWorld>(scenario.settings, seed);
  } else {
    return make_error("unknown platform '" + scenario.platform + "'");
  }
  return w;
}

}  // namespace contego::sim
