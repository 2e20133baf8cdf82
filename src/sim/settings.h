// Reading scenario values: durations with units and typed `set` settings.
#ifndef CONTEGO_SIM_SETTINGS_H_
#define CONTEGO_SIM_SETTINGS_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace contego::sim {

// "200ms", "1.5s", "250us", "2min", "30h" -> microseconds; nullopt if malformed or
// without a unit.
std::optional<uint64_t> parse_duration_us(std::string_view text);
std::optional<int64_t> parse_int(std::string_view text);  // decimal or 0x hex, optional sign
std::optional<double> parse_double(std::string_view text);

using Settings = std::map<std::string, std::string>;

// Typed lookups with a default for keys the scenario does not set. Values
// were validated when the scenario was parsed (see scenario.cc), so a bad
// value here falls back to the default.
std::string setting_string(const Settings& s, const std::string& key, const std::string& fallback);
int64_t setting_int(const Settings& s, const std::string& key, int64_t fallback);
double setting_double(const Settings& s, const std::string& key, double fallback);
uint64_t setting_duration_us(const Settings& s, const std::string& key, uint64_t fallback);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_SETTINGS_H_
