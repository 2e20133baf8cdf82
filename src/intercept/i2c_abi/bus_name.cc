#include "intercept/i2c_abi/bus_name.h"

#include <vector>

namespace contego::intercept {

int bus_number(const std::string& path) {
  std::string rest;
  if (path.rfind("/dev/i2c-", 0) == 0 || path.rfind("/dev/i2c/", 0) == 0) {
    rest = path.substr(9);
  } else {
    return -1;
  }
  if (rest.empty() || rest.size() > 3) return -1;
  int n = 0;
  for (char c : rest) {
    if (c < '0' || c > '9') return -1;
    n = n * 10 + (c - '0');
  }
  return n <= 255 ? n : -1;
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
