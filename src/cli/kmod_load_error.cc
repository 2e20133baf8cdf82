// `contego kmod load`'s words for a refused CONTEGO_KMOD_LOAD. The request
// is versioned (kernel/contego_kmod.h): a module of CONTEGO_KMOD_LOAD_VERSION
// 2 or later refuses a request of another size or version with EPROTO and,
// for another version, writes its own back; a module from before the
// versioned request does not know its number (ENOTTY). The message says
// which side is out of date and which build to take.
#include "cli/kmod_load_error.h"

#include <cerrno>
#include <cstring>
#include <fmt/core.h>

namespace contego::cli {

std::string kmod_load_error(int err, const contego_kmod_load& r) {
  constexpr uint32_t kOurs = CONTEGO_KMOD_LOAD_VERSION;
  if (r.status != 0) {
    return fmt::format(
        "contego kmod: the module's verifier refused the image: status {} (section {}, index {}); "
        "the policy in force stays",
        r.status, r.section, r.index);
  }
  if (err == ENOTTY) {
    return fmt::format(
        "contego kmod: load refused: the module is older than this contego (it predates the "
        "versioned load request, version {}: no per-task limits); load the contego.ko built "
        "with this contego",
        kOurs);
  }
  if (err == EPROTO && r.version < kOurs) {
    return fmt::format(
        "contego kmod: load refused: the module is older than this contego (it takes load "
        "request version {}, this contego sends version {}); load the contego.ko built with "
        "this contego",
        r.version, kOurs);
  }
  if (err == EPROTO && r.version > kOurs) {
    return fmt::format(
        "contego kmod: load refused: this contego is older than the module (it takes load "
        "request version {}, this contego sends version {}); use the contego built with the "
        "loaded contego.ko",
        r.version, kOurs);
  }
  if (err == EPROTO) {
    return fmt::format(
        "contego kmod: load refused: the module takes a load request of another size than this "
        "contego's version {} ({} bytes; the kernel log names the module's version and size): "
        "they are from different builds; load the contego.ko built with this contego",
        kOurs, sizeof(contego_kmod_load));
  }
  return fmt::format("contego kmod: load failed: {}", std::strerror(err));
}

}  // namespace contego::cli
