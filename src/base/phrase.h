// An enum value's name or phrase read from a table of {value, text} pairs:
// the table states each value's text once, and a value not in it gets the
// caller's fallback.
#ifndef CONTEGO_BASE_PHRASE_H_
#define CONTEGO_BASE_PHRASE_H_

#include <cstddef>
#include <string_view>
#include <utility>

namespace contego {

template <typename Enum>
using PhraseTable = std::pair<Enum, std::string_view>;

template <typename Enum, size_t N>
constexpr std::string_view phrase_of(Enum value, const PhraseTable<Enum> (&table)[N],
                                     std::string_view fallback) {
  for (const auto& [v, text] : table) {
    if (v == value) return text;
  }
  return fallback;
}

}  // namespace contego

#endif  // CONTEGO_BASE_PHRASE_H_
