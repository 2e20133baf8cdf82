// Reload in place, for both enclave clients (`contego reload` in the
// monitor, `contego kmod reload` for contego.ko): which records of the
// running image (`old`) each record of the new image (`now`) continues, by
// name. The devices must be the running policy's (the same names, buses,
// addresses and profiles, in the same order); a task pairs with the task of
// the same name and id; a command, rate limit or invariant with the one of
// the same name on the same device (and task, scope, field count). The core
// checks every pair again (core::Checker::carry_from).
#ifndef CONTEGO_CLI_CARRY_PAIRS_H_
#define CONTEGO_CLI_CARRY_PAIRS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "base/result.h"
#include "image/image_model.h"

namespace contego::cli {

struct Pairing {
  // Per record of the new image, in its order: the old image's id, or kNone.
  std::vector<uint16_t> tasks, devices, commands, rates, invariants;
  std::vector<bool> kept;           // per task of the new image: paired
  std::vector<std::string> afresh;  // "task NAME", "command NAME"...: what starts afresh
  size_t paired = 0;                // commands, rate limits and invariants paired
};

// Refused (with the reason) when the devices differ.
Result<Pairing> pair_for_carry(const image::ImageModel& now, const image::ImageModel& old);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_CARRY_PAIRS_H_
