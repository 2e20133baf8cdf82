#include "sched/duration.h"

#include <array>
#include <cctype>

namespace contego::sched {
namespace {

struct Unit {
  std::string_view suffix;
  Nanos scale;
};

// Longest suffixes first so "ms" is not read as "s".
constexpr std::array<Unit, 5> kUnits = {{{"µs", kNanosPerMicro},
                                         {"ns", 1},
                                         {"us", kNanosPerMicro},
                                         {"ms", kNanosPerMilli},
                                         {"s", kNanosPerSecond}}};

Error bad(std::string_view text, std::string_view why) {
  return make_error("invalid duration '" + std::string(text) + "': " + std::string(why));
}

}  // namespace

Result<Nanos> parse_duration(std::string_view text) {
  std::string_view s = text;
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  if (s.empty()) return bad(text, "empty");
  if (s.front() == '-') return bad(text, "negative");
  if (s == "0") return Nanos{0};

  Nanos scale = 0;
  for (const Unit& u : kUnits) {
    if (s.size() > u.suffix.size() && s.substr(s.size() - u.suffix.size()) == u.suffix) {
      scale = u.scale;
      s.remove_suffix(u.suffix.size());
      break;
    }
  }
  if (scale == 0) return bad(text, "missing unit (use ns, us, ms or s, e.g. 250us)");

  // Integer part and fraction, accumulated exactly in nanoseconds.
  Nanos whole = 0;
  size_t i = 0;
  size_t digits = 0;
  for (; i < s.size() && std::isdigit(static_cast<unsigned char>(s[i])); ++i, ++digits) {
    if (whole > kMaxDuration) return bad(text, "too large");
    whole = whole * 10 + (s[i] - '0');
  }
  if (whole > kMaxDuration / scale) return bad(text, "too large (limit 1000000s)");
  Nanos value = whole * scale;
  if (i < s.size() && s[i] == '.') {
    ++i;
    Nanos place = scale;
    size_t frac_digits = 0;
    for (; i < s.size() && std::isdigit(static_cast<unsigned char>(s[i])); ++i, ++frac_digits) {
      const int d = s[i] - '0';
      if (place % 10 != 0) {
        if (d != 0) return bad(text, "finer than a nanosecond");
        continue;
      }
      place /= 10;
      value += d * place;
    }
    if (frac_digits == 0) return bad(text, "no digits after '.'");
  }
  if (digits == 0) return bad(text, "no digits before the unit");
  if (i != s.size()) return bad(text, "unexpected character '" + std::string(1, s[i]) + "'");
  if (value > kMaxDuration) return bad(text, "too large (limit 1000000s)");
  return value;
}

std::string format_duration(Nanos ns) {
  if (ns == 0) return "0";
  std::string sign;
  // Negative values appear only as slack of a task that misses its deadline.
  unsigned long long v =
      ns < 0 ? 0ULL - static_cast<unsigned long long>(ns) : static_cast<unsigned long long>(ns);
  if (ns < 0) sign = "-";
  struct Pick {
    unsigned long long scale;
    const char* suffix;
  };
  constexpr std::array<Pick, 4> picks = {
      {{1'000'000'000ULL, "s"}, {1'000'000ULL, "ms"}, {1'000ULL, "us"}, {1ULL, "ns"}}};
  for (const Pick& p : picks) {
    if (v < p.scale) continue;
    std::string out = sign + std::to_string(v / p.scale);
    unsigned long long frac = v % p.scale;
    if (frac != 0) {
      std::string digits = std::to_string(frac);
      std::string pad(std::to_string(p.scale).size() - 1 - digits.size(), '0');
      digits = pad + digits;
      while (digits.back() == '0') digits.pop_back();
      out += "." + digits;
    }
    return out + p.suffix;
  }
  return "0";
}

}  // namespace contego::sched
