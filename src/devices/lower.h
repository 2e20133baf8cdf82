// Lowering device profiles into image records, and building a ProfileSpec for
// a generic register map declared in a policy.
//
// Host code: allocates, returns Result<T>; never linked into the trusted core.
#ifndef CONTEGO_DEVICES_LOWER_H_
#define CONTEGO_DEVICES_LOWER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "devices/profile.h"
#include "image/image_model.h"

namespace contego::devices {

// Where one `device` declaration of a policy puts a profile.
struct DeviceBinding {
  std::string name;  // the policy's device name ("gopigo"); becomes the DeviceRecord's name
  uint8_t bus = 1;   // i2c-N
  uint16_t addr = 0;
  bool ten_bit = false;
  // Sensors (ignored when the profile has no sensor role).
  uint32_t sample_period_us = 0;
  uint32_t max_sample_age_us = 0;
  // Latching (`latch after K violations within W`).
  core::LatchMode latch_mode = core::LatchMode::kOff;
  uint8_t latch_count = 0;
  uint32_t latch_window_us = 0;
};

// Checks that a profile can be lowered: names unique and non-empty, field
// geometry inside the frame / register group / sample, ranges representable
// in the field, frame opcodes unique, register groups inside 0..255 and not
// overlapping. The message names the profile and the offending part.
Status validate_profile(const ProfileSpec& profile);

// Appends one device: a DeviceRecord, its CommandRecords and FieldRecords
// (contiguous, in profile order, so command k of the profile is global
// command `command_first + k` and its field f is field `field_first + f`),
// its RegisterInitRecords (power-on values) and AliasRecords. Names are
// filled. The safe state is left empty (safe_first = 0, safe_count = 0): the
// compiler sets it after adding templates. Returns the new device id, or an
// error if the profile is invalid or a limit of contego/core/limits.h would
// be exceeded.
Result<uint16_t> append_device(image::ImageModel& model, const ProfileSpec& profile,
                               const DeviceBinding& binding);

// Global command id of `command` on device `device` of a model built with
// append_device, or nullopt.
std::optional<uint16_t> find_command(const image::ImageModel& model, uint16_t device,
                                     std::string_view command);

// A command of a profile by name, or nullptr.
const CommandSpec* find_command(const ProfileSpec& profile, std::string_view command);

// The slot (0-based position, the operand of Op::kField) of a field of a
// command, or nullopt.
std::optional<uint8_t> find_field_slot(const CommandSpec& command, std::string_view field);

// A kRaw SignalRecord for sample field `field` of sensor `device` (valid range
// = the field's range); nullopt if the profile has no such sample field.
std::optional<core::SignalRecord> make_raw_signal(const ProfileSpec& profile, uint16_t device,
                                                  std::string_view field);

// --- generic register maps declared in a policy --------------------------------

// One register (or a run of consecutive registers holding one value):
// `register 0x02..0x03 flow : u16le range 0..4000` becomes a command `flow`
// with one field `value`.
struct RegisterDecl {
  std::string name;
  uint8_t first = 0;   // first register
  uint8_t nbytes = 1;  // 1..4 consecutive registers
  bool big_endian = false;
  bool is_signed = false;
  int64_t min = 0;  // legal values
  int64_t max = 255;
  std::string unit;
  core::CommandClass command_class = core::CommandClass::kActuate;
};

struct RegisterRange {
  uint8_t first = 0;  // inclusive
  uint8_t last = 0;   // inclusive
};

struct RegmapDecl {
  std::string name;  // profile name, usually the device's name
  uint8_t role = core::kRoleActuator;
  bool auto_increment = false;  // multi-byte writes fill consecutive registers
  std::vector<RegisterDecl> registers;
  std::vector<RegisterRange> forbidden;  // become kForbidden commands named forbid_0xNN
  std::vector<RegisterValue> power_on;   // non-zero reset values
  // Sensors: e.g. sample_request {0x00}, sample_len 4, fields level (u16be @0), temp (i16be @2).
  std::vector<uint8_t> sample_request;
  uint8_t sample_len = 0;
  std::vector<FieldSpec> sample_fields;
};

// Builds and validates the profile. Registers not declared (and not
// forbidden) stay uncovered, and the core refuses writes to them.
Result<ProfileSpec> make_regmap_profile(const RegmapDecl& decl);

// A field of `nbytes` bytes at `offset` holding an integer of that size
// (for sample fields of generic sensors).
FieldSpec make_int_field(std::string name, uint8_t offset, uint8_t nbytes, bool big_endian,
                         bool is_signed, int64_t min, int64_t max, std::string unit = "");

}  // namespace contego::devices

#endif  // CONTEGO_DEVICES_LOWER_H_
