#include "intercept/seccomp/remote_memory.h"

#include <limits.h>

#include <cstring>

namespace contego::intercept::seccomp {

bool read_path(i2c_abi::Memory& mem, uint64_t addr, std::string* out) {
  out->clear();
  char chunk[256];
  while (out->size() < PATH_MAX) {
    // Read byte-wise near page ends would be slow; read a chunk and fall back
    // to single bytes when the chunk crosses into an unmapped page.
    if (mem.read(addr + out->size(), chunk, sizeof chunk)) {
      const void* nul = memchr(chunk, 0, sizeof chunk);
      if (nul != nullptr) {
        out->append(chunk, static_cast<const char*>(nul) - chunk);
        return true;
      }
      out->append(chunk, sizeof chunk);
      continue;
    }
    char c;
    if (!mem.read(addr + out->size(), &c, 1)) return false;
    if (c == 0) return true;
    out->push_back(c);
  }
  return false;
}

}  // namespace contego::intercept::seccomp
