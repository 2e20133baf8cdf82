// Recovering a device's ProfileSpec from a compiled image model, for tools
// that only have the image (the test runner, the simulator, `contego dump`).
#ifndef CONTEGO_DEVICES_MODEL_PROFILE_H_
#define CONTEGO_DEVICES_MODEL_PROFILE_H_

#include <cstdint>

#include "base/result.h"
#include "devices/profile.h"
#include "image/image_model.h"

namespace contego::devices {

// The profile of device `device`. If its records are exactly those a
// built-in profile lowers to, that profile is returned (with its ranges and
// sample fields); otherwise one is rebuilt from the records: field ranges are
// what the geometry can hold, group names are group numbers, and the sample
// fields are the device's raw signals (named as the signals, a "device."
// prefix removed).
Result<ProfileSpec> profile_from_model(const image::ImageModel& model, uint16_t device);

}  // namespace contego::devices

#endif  // CONTEGO_DEVICES_MODEL_PROFILE_H_
