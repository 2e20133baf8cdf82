// JSON text for output that may carry bytes from untrusted input (policy
// source, task names from a client, file names). nlohmann::json throws on
// invalid UTF-8 when it serialises; here such bytes become U+FFFD instead,
// so a hostile string costs a replacement character, never the process.
#ifndef CONTEGO_BASE_JSON_TEXT_H_
#define CONTEGO_BASE_JSON_TEXT_H_

#include <nlohmann/json.hpp>
#include <string>

namespace contego {

// indent < 0: one line (the audit log's form); otherwise pretty-printed.
inline std::string json_text(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace contego

#endif  // CONTEGO_BASE_JSON_TEXT_H_
