// What contego.ko enforces and how it is doing, read through its control
// node: the image in force (read back), its names, the module's counters,
// a degraded load's gaps and the latched devices, as `contego kmod status
// --json` prints them; and the same as Prometheus metrics, which `contego
// kmod audit --metrics-file` writes (the monitor's --metrics-file for the
// kernel client).
#ifndef CONTEGO_CLI_KMOD_STATUS_H_
#define CONTEGO_CLI_KMOD_STATUS_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "base/result.h"
#include "image/image_model.h"

namespace contego::cli {

// The image in force in the module, read back (CONTEGO_KMOD_IMAGE), and its CRC.
Result<std::pair<std::vector<uint8_t>, uint32_t>> running_image(int fd);

// The devices of `mask` (bit d: device d), named from the image.
std::string devices_named(const image::ImageModel& model, uint32_t mask);

// The module's state from its control node `fd` (CONTEGO_KMOD_STATS, then
// the image in force): loaded, image_sha256/crc32/bytes, tasks, devices
// (each with latched, undriven, unread), degraded and latched in words,
// audit_reader, counters.
Result<nlohmann::ordered_json> kmod_status(int fd);

// That state in Prometheus's text exposition format.
std::string kmod_metrics_text(const nlohmann::ordered_json& status);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_KMOD_STATUS_H_
