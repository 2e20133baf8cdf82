// CRC-32 of the image checksum. Table-free (bitwise): the verifier runs once
// per load, so a 1 KiB table in the trusted core is not worth its size.
#include "core/internal.h"

namespace contego::core::internal {

uint32_t crc32(const uint8_t* data, size_t len) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < len; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) {
      crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
  }
  return crc ^ 0xFFFFFFFFu;
}

}  // namespace contego::core::internal
