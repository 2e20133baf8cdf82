#include "intercept/i2c_abi/bus_name.h"

#include <vector>

#include "base/bus_number.h"

namespace contego::intercept {

int bus_number(const std::string& path) {
  if (path.rfind("/dev/i2c-", 0) != 0 && path.rfind("/dev/i2c/", 0) != 0) return -1;
  return parse_bus_number(std::string_view(path).substr(9));
}

std::string lexical_normalise(const std::string& path) {
  std::vector<std::string> parts;
  size_t i = 0;
  while (i <= path.size()) {
    size_t j = path.find('/', i);
    if (j == std::string::npos) j = path.size();
    const std::string part = path.substr(i, j - i);
    if (part == "..") {
      if (!parts.empty()) parts.pop_back();
    } else if (!part.empty() && part != ".") {
      parts.push_back(part);
    }
    i = j + 1;
  }
  std::string out;
  for (const auto& p : parts) out += "/" + p;
  return out.empty() ? "/" : out;
}

}  // namespace contego::intercept
