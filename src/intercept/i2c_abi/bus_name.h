// The one parser of bus node names, shared by both enclave clients (the
// seccomp supervisor's bus_path.h and the preload shim): which bus a path of
// the form /dev/i2c-N or /dev/i2c/N names, after lexical normalisation.
#ifndef CONTEGO_INTERCEPT_I2C_ABI_BUS_NAME_H_
#define CONTEGO_INTERCEPT_I2C_ABI_BUS_NAME_H_

#include <string>

namespace contego::intercept {

// The bus number of /dev/i2c-N or /dev/i2c/N (N in 0..255, decimal digits
// only), else -1. The path is taken as it is: normalise it first.
int bus_number(const std::string& path);

// `path` with `.`, `..` and repeated slashes removed (`..` of / is /).
std::string lexical_normalise(const std::string& path);

}  // namespace contego::intercept

#endif  // CONTEGO_INTERCEPT_I2C_ABI_BUS_NAME_H_
