// Device profiles: what the bytes sent to a kind of device mean. A profile is
// host-side data that the policy compiler lowers into image records
// (DeviceRecord / CommandRecord / FieldRecord / RegisterInitRecord /
// AliasRecord); the trusted core decodes with those records and knows no
// device by name.
//
// Built-in profiles: pca9685, gopigo2, line_follower. A policy can declare a
// generic register-map profile for a device contego does not know; the
// compiler builds a ProfileSpec for it from the declaration.
#ifndef CONTEGO_DEVICES_PROFILE_H_
#define CONTEGO_DEVICES_PROFILE_H_

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "contego/core/image.h"

namespace contego::devices {

struct FieldSpec {
  std::string name;            // "speed", "off", "channel"...
  core::FieldRecord geometry;  // where it sits (name offset filled by the image writer)
  int64_t min = 0;             // legal range of the value, for the compiler's range checks
  int64_t max = 0;
  std::string unit;  // "", "ticks", "ms" ... (documentation and unit checks)
  // A one-bit override that forces the output fully on or off whatever the
  // pulse (PCA9685 full_on / full_off). A fail-safe that does not name it
  // writes 0, never the value the device's shadow holds (power-on: full off).
  bool output_override = false;
};

struct CommandSpec {
  std::string name;   // "set_left_speed", "fwd", "led" (register-map group), "mode1"
  std::string group;  // substitution group ("motion", "left_speed", "led", ...)
  core::CommandClass command_class = core::CommandClass::kActuate;
  // kFrame: opcode. kRegisterMap: base register, group length, repeat, stride.
  uint8_t match = 0;
  uint8_t group_len = 0;
  uint8_t repeat = 0;
  uint8_t stride = 0;
  std::vector<FieldSpec> fields;
  std::string doc;  // one line: what the device does with it
};

struct RegisterValue {
  uint8_t reg;
  uint8_t value;
};

struct AliasSpec {
  core::AliasKind kind;
  uint16_t addr;  // kAddress: the extra address (e.g. PCA9685 all-call 0x70); 0 for general call
};

// Register map: a command whose writes the device also loads into every
// channel of a repeated command (PCA9685: ALL_LED_* fill all LEDn registers).
struct BroadcastSpec {
  std::string from;  // a command with one group (repeat 1)
  std::string to;    // a repeated command with groups as long
};

// A register-map command the device takes only while a bit of its mode
// register (`ai_reg`) is set; written otherwise, the device drops it.
struct GateSpec {
  std::string command;  // a command with one group (PCA9685: prescale)
  uint8_t bit = 0;      // PCA9685: 4, MODE1 SLEEP
};

struct ProfileSpec {
  std::string name;  // as written after ':' in a policy: "gopigo2"
  core::Profile kind = core::Profile::kFrame;
  uint8_t role = core::kRoleActuator;  // DeviceRole bits
  // kFrame
  uint8_t frame_len = 0;
  uint8_t prefix_len = 0;
  bool short_queries = false;  // a one-byte write [opcode] of a query is that query
  // kRegisterMap
  core::AutoIncrement auto_increment = core::AutoIncrement::kNever;
  uint8_t ai_reg = 0;
  uint8_t ai_bit = 0;
  std::vector<RegisterValue> power_on;  // registers whose reset value is not 0
  std::vector<AliasSpec> aliases;
  std::vector<CommandSpec> commands;
  std::optional<BroadcastSpec> broadcast;
  std::optional<GateSpec> gate;
  // Register map: drivers read registers back (a task may be given `reads`
  // without the device being a sensor). Host-side only; not in the image.
  bool read_back = false;
  // Sensors: how the trusted side takes a sample and what is in it.
  std::vector<uint8_t> sample_request;  // written before each sample read (may be empty)
  uint8_t sample_len = 0;
  std::vector<FieldSpec> sample_fields;  // raw signals: "raw0".."raw4" ...
  std::string doc;
};

std::span<const ProfileSpec> builtin_profiles();
const ProfileSpec* find_builtin_profile(std::string_view name);

}  // namespace contego::devices

#endif  // CONTEGO_DEVICES_PROFILE_H_
