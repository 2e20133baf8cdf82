// Host-side encoding and decoding of device traffic with a ProfileSpec: what
// tests, `contego test` and the simulator use to turn "set_left_speed(85)"
// into bus bytes and bus bytes back into readable commands.
//
// HostDecoder mirrors the decoding rules of contego/core/image.h (frame
// lengths and prefixes, register groups, staging, auto-increment) so that
// profiles can be tested without the trusted core. It is a reference model,
// not the enforcement point: the core decodes with the image records.
//
// Host code: allocates, returns Result<T>.
#ifndef CONTEGO_DEVICES_CODEC_H_
#define CONTEGO_DEVICES_CODEC_H_

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "devices/profile.h"

namespace contego::devices {

struct FieldValue {
  std::string name;
  int64_t value = 0;
};

struct EncodeOptions {
  // kFrame: send the profile's prefix (e.g. the GoPiGo's dummy 0x01 register
  // byte) before the frame when the profile has one.
  bool with_prefix = true;
  uint8_t prefix_byte = 0x01;
  // kRegisterMap: which repetition of the group (PCA9685 channel).
  uint32_t index = 0;
  // kRegisterMap: false = one auto-increment write [reg, b0, b1, ...] (the
  // device must have auto-increment on); true = one [reg, b] write per register.
  bool per_register = false;
};

// The writes (each one bus write transaction) that send `command` with the
// given field values; unnamed fields are 0. Errors: unknown command or field,
// value outside the field's range, index outside the group's repeat count.
Result<std::vector<std::vector<uint8_t>>> encode_command(const ProfileSpec& profile,
                                                         std::string_view command,
                                                         std::span<const FieldValue> fields,
                                                         const EncodeOptions& options = {});

// A sensor sample (sample_len bytes) holding the given sample-field values;
// unnamed fields are 0.
Result<std::vector<uint8_t>> encode_sample(const ProfileSpec& profile,
                                           std::span<const FieldValue> fields);

// Reads one field from `bytes` as the core does: nbytes at offset, little- or
// big-endian, >> shift, masked to width, sign-extended if signed. Fails if
// the bytes are too short.
Result<int64_t> extract_field(const core::FieldRecord& field, std::span<const uint8_t> bytes);

struct DecodedCommand {
  const CommandSpec* command = nullptr;
  uint32_t index = 0;           // register maps: group repetition (channel); frames: 0
  std::vector<int64_t> values;  // one per field of `command`, in order
};

// A device's decoding state: for register maps the shadow registers
// (starting at the power-on values) and the staged bytes of groups not yet
// complete. Frames are stateless.
class HostDecoder {
 public:
  explicit HostDecoder(const ProfileSpec& profile);

  // Decodes one write transaction into the commands it completes (none for a
  // register-pointer write or a partly written group). Every completed
  // command is assumed to reach the device (shadow registers are updated).
  // Errors name the problem: bad frame length, unknown opcode, register not
  // covered by the profile.
  Result<std::vector<DecodedCommand>> write(std::span<const uint8_t> bytes);

  uint8_t reg(uint8_t r) const { return shadow_[r]; }
  const ProfileSpec& profile() const { return *profile_; }

 private:
  Result<std::vector<DecodedCommand>> write_frame(std::span<const uint8_t> bytes);
  Result<std::vector<DecodedCommand>> write_short_query(uint8_t opcode);
  Result<std::vector<DecodedCommand>> write_registers(std::span<const uint8_t> bytes);

  const ProfileSpec* profile_;
  std::array<uint8_t, 256> shadow_{};
  std::array<uint8_t, 256> staged_{};
  std::array<bool, 256> is_staged_{};
};

// "set_left_speed(speed=85)", "led(5, on=0, off=420, full_on=0, full_off=0)", "fwd()".
std::string describe(const DecodedCommand& command);

// Decodes `bytes` as one write to a device in its power-on state and
// describes the commands; several are joined with "; ", a write that
// completes none gives "(no command)".
Result<std::string> describe(const ProfileSpec& profile, std::span<const uint8_t> bytes);

}  // namespace contego::devices

#endif  // CONTEGO_DEVICES_CODEC_H_
