#include "sim/settings.h"

#include <charconv>
#include <cmath>

namespace contego::sim {

std::optional<int64_t> parse_int(std::string_view text) {
  bool neg = false;
  if (!text.empty() && (text[0] == '-' || text[0] == '+')) {
    neg = text[0] == '-';
    text.remove_prefix(1);
  }
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  }
  if (text.empty()) return std::nullopt;
  int64_t v = 0;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v, base);
  if (ec != std::errc() || p != text.data() + text.size()) return std::nullopt;
  return neg ? -v : v;
}

std::optional<double> parse_double(std::string_view text) {
  if (text.empty()) return std::nullopt;
  double v = 0;
  auto [p, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || p != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<uint64_t> parse_duration_us(std::string_view text) {
  struct Unit {
    std::string_view suffix;
    double us;
  };
  static constexpr Unit kUnits[] = {
      {"us", 1.0}, {"ms", 1e3}, {"min", 60e6}, {"s", 1e6}, {"h", 3600e6}};
  for (const auto& u : kUnits) {
    if (text.size() > u.suffix.size() && text.ends_with(u.suffix)) {
      auto v = parse_double(text.substr(0, text.size() - u.suffix.size()));
      if (!v || *v < 0) return std::nullopt;
      return static_cast<uint64_t>(std::llround(*v * u.us));
    }
  }
  return std::nullopt;
}

std::string setting_string(const Settings& s, const std::string& key, const std::string& fallback) {
  auto it = s.find(key);
  return it == s.end() ? fallback : it->second;
}

int64_t setting_int(const Settings& s, const std::string& key, int64_t fallback) {
  auto it = s.find(key);
  if (it == s.end()) return fallback;
  return parse_int(it->second).value_or(fallback);
}

double setting_double(const Settings& s, const std::string& key, double fallback) {
  auto it = s.find(key);
  if (it == s.end()) return fallback;
  return parse_double(it->second).value_or(fallback);
}

uint64_t setting_duration_us(const Settings& s, const std::string& key, uint64_t fallback) {
  auto it = s.find(key);
  if (it == s.end()) return fallback;
  return parse_duration_us(it->second).value_or(fallback);
}

}  // namespace contego::sim
