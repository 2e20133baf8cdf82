// The number of an I2C bus as Linux names it in /dev/i2c-N: the one reading
// of N, shared by the enclave clients' bus paths and `--bus` arguments.
#ifndef CONTEGO_BASE_BUS_NUMBER_H_
#define CONTEGO_BASE_BUS_NUMBER_H_

#include <string_view>

namespace contego {

// `digits` as a bus number: 1 to 3 decimal digits, 0..255; else -1.
inline int parse_bus_number(std::string_view digits) {
  if (digits.empty() || digits.size() > 3) return -1;
  int n = 0;
  for (char c : digits) {
    if (c < '0' || c > '9') return -1;
    n = n * 10 + (c - '0');
  }
  return n <= 255 ? n : -1;
}

}  // namespace contego

#endif  // CONTEGO_BASE_BUS_NUMBER_H_
