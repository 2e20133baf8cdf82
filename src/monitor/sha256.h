// SHA-256 (FIPS 180-4) for the audit log's hash chain. Host code, backed by
// OpenSSL's libcrypto, which uses the CPU's SHA extensions where it has them
// (x86 SHA-NI, Armv8 crypto): a record's hash is on the path of every
// checked command (docs/libraries.md).
#ifndef CONTEGO_MONITOR_SHA256_H_
#define CONTEGO_MONITOR_SHA256_H_

#include <string>
#include <string_view>

namespace contego::monitor {

// Lower-case hex digest of `text`.
std::string sha256_hex(std::string_view text);
// The same into `out` (64 digits and a NUL), without allocating.
void sha256_hex(std::string_view text, char out[65]);

}  // namespace contego::monitor

#endif  // CONTEGO_MONITOR_SHA256_H_
