// The built-in device profiles. Every number here comes from the vendors'
// firmware and libraries or the NXP datasheet; docs/devices.md lists the
// commands with their sources.
#include <array>

#include "devices/profile.h"

namespace contego::devices {
namespace {

using core::CommandClass;

// A field of `nbytes` bytes at `offset`, `width` bits after shifting right by `shift`.
FieldSpec field(std::string name, uint8_t offset, uint8_t nbytes, uint8_t shift, uint8_t width,
                bool big_endian, int64_t min, int64_t max, std::string unit = "") {
  FieldSpec f;
  f.name = std::move(name);
  f.geometry = core::FieldRecord{};
  f.geometry.offset = offset;
  f.geometry.nbytes = nbytes;
  f.geometry.shift = shift;
  f.geometry.width = width;
  f.geometry.flags = big_endian ? core::kFieldBigEndian : 0;
  f.min = min;
  f.max = max;
  f.unit = std::move(unit);
  return f;
}

// One byte of a frame (opcode = byte 0), full range unless narrowed.
FieldSpec byte_field(std::string name, uint8_t offset, int64_t min = 0, int64_t max = 255,
                     std::string unit = "") {
  return field(std::move(name), offset, 1, 0, 8, false, min, max, std::move(unit));
}

// A single bit of a register (offset within the command's register group).
FieldSpec bit_field(std::string name, uint8_t offset, uint8_t bit) {
  return field(std::move(name), offset, 1, bit, 1, false, 0, 1);
}

CommandSpec frame_command(std::string name, uint8_t opcode, CommandClass cls, std::string group,
                          std::vector<FieldSpec> fields, std::string doc) {
  CommandSpec c;
  c.name = std::move(name);
  c.group = std::move(group);
  c.command_class = cls;
  c.match = opcode;
  c.fields = std::move(fields);
  c.doc = std::move(doc);
  return c;
}

CommandSpec register_command(std::string name, uint8_t base, uint8_t group_len, uint8_t repeat,
                             uint8_t stride, CommandClass cls, std::vector<FieldSpec> fields,
                             std::string doc) {
  std::string group = name;  // a register command is its own group
  CommandSpec c = frame_command(std::move(name), base, cls, std::move(group), std::move(fields),
                                std::move(doc));
  c.group_len = group_len;
  c.repeat = repeat;
  c.stride = stride;
  return c;
}

ProfileSpec make_gopigo2() {
  constexpr auto kAct = CommandClass::kActuate;
  constexpr auto kQuery = CommandClass::kQuery;
  ProfileSpec p;
  p.name = "gopigo2";
  p.kind = core::Profile::kFrame;
  p.role = core::kRoleActuator;
  p.frame_len = 4;   // [cmd, v1, v2, v3]
  p.prefix_len = 1;  // the C and old Python libraries send a dummy 0x01 register byte first
  p.doc = "Dexter Industries GoPiGo/GoPiGo2 motor firmware (fw 1.6), 4-byte command frames";

  auto motion = [&](std::string name, uint8_t opcode, std::string doc) {
    p.commands.push_back(
        frame_command(std::move(name), opcode, kAct, "motion", {}, std::move(doc)));
  };
  motion("fwd", 105, "drive forward (Python library; no PID)");
  motion("fwd_pid", 119, "drive forward (C library; firmware treats it as fwd)");
  motion("bwd", 107, "drive backward (no PID)");
  motion("bwd_pid", 115, "drive backward (PID variant)");
  motion("left", 97, "turn left, one motor stopped");
  motion("left_rot", 98, "spin left, motors in opposite directions");
  motion("right", 100, "turn right, one motor stopped");
  motion("right_rot", 110, "spin right, motors in opposite directions");
  motion("stop", 120, "stop both motors");

  auto& c = p.commands;
  c.push_back(frame_command("increase_speed", 116, kAct, "speed_step", {},
                            "both speeds += 10 (saturates at 255)"));
  c.push_back(frame_command("decrease_speed", 103, kAct, "speed_step", {},
                            "both speeds -= 10 (saturates at 0)"));
  c.push_back(frame_command("set_left_speed", 70, kAct, "left_speed",
                            {byte_field("speed", 1, 0, 255)},
                            "left motor speed (firmware speed2)"));
  c.push_back(frame_command("set_right_speed", 71, kAct, "right_speed",
                            {byte_field("speed", 1, 0, 255)},
                            "right motor speed (firmware speed1)"));
  c.push_back(frame_command("motor1", 111, kAct, "motor1",
                            {byte_field("dir", 1, 0, 1), byte_field("speed", 2, 0, 255)},
                            "drive motor 1 directly: direction and speed"));
  c.push_back(frame_command("motor2", 112, kAct, "motor2",
                            {byte_field("dir", 1, 0, 1), byte_field("speed", 2, 0, 255)},
                            "drive motor 2 directly: direction and speed"));
  c.push_back(frame_command(
      "enc_tgt", 50, kAct, "enc_tgt",
      {byte_field("motors", 1, 0, 3), field("ticks", 2, 2, 0, 16, true, 0, 65535, "ticks")},
      "stop after `ticks` encoder ticks on the selected motors (m1*2+m2); resets counters"));
  c.push_back(frame_command("enable_encoders", 51, kAct, "encoders", {}, "attach encoder ISRs"));
  c.push_back(frame_command("disable_encoders", 52, kAct, "encoders", {}, "detach encoder ISRs"));
  c.push_back(frame_command("enc_read", 53, kQuery, "enc_read", {byte_field("motor", 1, 0, 1)},
                            "load the 2-byte tick count of a motor"));
  c.push_back(frame_command("read_motor_speed", 114, kQuery, "read_motor_speed", {},
                            "load [speed1, speed2]"));
  c.push_back(frame_command("volt", 118, kQuery, "volt", {}, "load the battery ADC value"));
  c.push_back(frame_command("us_dist", 117, kQuery, "us_dist", {byte_field("pin", 1, 0, 255)},
                            "load the ultrasonic distance (cm) measured on a pin"));
  c.push_back(frame_command("servo", 101, kAct, "servo", {byte_field("angle", 1, 0, 180, "deg")},
                            "software servo angle"));
  c.push_back(
      frame_command("enable_servo", 61, kAct, "servo_power", {}, "start the servo refresh"));
  c.push_back(
      frame_command("disable_servo", 60, kAct, "servo_power", {}, "stop the servo refresh"));
  c.push_back(frame_command("enable_com_timeout", 80, kAct, "com_timeout",
                            {field("timeout", 1, 2, 0, 16, true, 0, 65535, "ms")},
                            "watchdog: stop the motors when no frame arrives for `timeout` ms"));
  c.push_back(frame_command("disable_com_timeout", 81, kAct, "com_timeout", {},
                            "switch the firmware watchdog off"));
  c.push_back(frame_command("fw_ver", 20, kQuery, "fw_ver", {}, "load the firmware version"));
  c.push_back(frame_command("trim_test", 30, kAct, "trim", {byte_field("value", 1, 0, 200)},
                            "motor-2 speed trim (value = trim + 100), volatile"));
  c.push_back(frame_command("trim_write", 31, kAct, "trim", {byte_field("value", 1, 0, 200)},
                            "motor-2 speed trim (value = trim + 100), persisted in EEPROM"));
  c.push_back(frame_command("trim_read", 32, kQuery, "trim_read", {}, "load the stored trim"));
  c.push_back(frame_command("digital_write", 12, kAct, "digital_write",
                            {byte_field("pin", 1, 0, 255), byte_field("value", 2, 0, 1)},
                            "drive any Arduino pin (forced to OUTPUT)"));
  c.push_back(frame_command("digital_read", 13, kQuery, "digital_read",
                            {byte_field("pin", 1, 0, 255)}, "load a pin's level"));
  c.push_back(frame_command("analog_read", 14, kQuery, "analog_read",
                            {byte_field("pin", 1, 0, 255)}, "load a 10-bit ADC reading"));
  c.push_back(frame_command("analog_write", 15, kAct, "analog_write",
                            {byte_field("pin", 1, 0, 255), byte_field("value", 2, 0, 255)},
                            "PWM output on a pin"));
  c.push_back(frame_command("pin_mode", 16, kAct, "pin_mode",
                            {byte_field("pin", 1, 0, 255), byte_field("mode", 2, 0, 1)},
                            "set a pin's direction (1 = output)"));
  c.push_back(frame_command("ir_read_signal", 21, kQuery, "ir_read_signal", {},
                            "load an IR code (disabled in firmware 1.6)"));
  c.push_back(frame_command("ir_recv_pin", 22, kAct, "ir_recv_pin", {byte_field("pin", 1, 0, 255)},
                            "select the IR receiver pin (disabled in firmware 1.6)"));
  c.push_back(frame_command("cpu_speed", 25, kQuery, "cpu_speed", {}, "load F_CPU in MHz"));
  c.push_back(frame_command("factory_test1", 10, CommandClass::kForbidden, "factory_test", {},
                            "manufacturing test, not for users"));
  c.push_back(frame_command("factory_test2", 11, CommandClass::kForbidden, "factory_test", {},
                            "manufacturing test, not for users"));
  return p;
}

ProfileSpec make_line_follower() {
  ProfileSpec p;
  p.name = "line_follower";
  p.kind = core::Profile::kFrame;
  p.role = core::kRoleSensor;
  p.frame_len = 4;
  p.prefix_len = 1;
  p.doc = "Dexter Industries red line follower: 5 IR reflectance sensors, 10-bit readings";
  p.commands.push_back(frame_command("read_sensors", 3, CommandClass::kQuery, "read_sensors", {},
                                     "latch the five sensor readings for the next 10-byte read"));
  // DI's current driver probes the board before each read: a one-byte
  // write [0x12], then a 20-byte read of the board name.
  p.short_queries = true;
  p.commands.push_back(frame_command("manufacturer", 0x11, CommandClass::kQuery, "identity", {},
                                     "load the 20-byte manufacturer name"));
  p.commands.push_back(frame_command("board_name", 0x12, CommandClass::kQuery, "identity", {},
                                     "load the 20-byte board name (\"Line Follower\")"));
  p.sample_request = {0x01, 0x03, 0x00, 0x00, 0x00};
  p.sample_len = 10;
  for (uint8_t i = 0; i < 5; ++i) {
    // High = dark. 0xFFFF (65535) marks a junk read; signals use 0..1023 as the valid range.
    p.sample_fields.push_back(
        field("raw" + std::to_string(i), static_cast<uint8_t>(2 * i), 2, 0, 16, true, 0, 1023));
  }
  return p;
}

// LEDn / ALL_LED: ON_L ON_H OFF_L OFF_H; 12-bit counts, bit 4 of the high bytes = full on/off.
std::vector<FieldSpec> led_fields() {
  FieldSpec full_on = bit_field("full_on", 1, 4), full_off = bit_field("full_off", 3, 4);
  full_on.output_override = full_off.output_override = true;
  return {field("on", 0, 2, 0, 12, false, 0, 4095, "ticks"),
          field("off", 2, 2, 0, 12, false, 0, 4095, "ticks"), std::move(full_on),
          std::move(full_off)};
}

ProfileSpec make_pca9685() {
  constexpr auto kAct = CommandClass::kActuate;
  ProfileSpec p;
  p.name = "pca9685";
  p.kind = core::Profile::kRegisterMap;
  p.role = core::kRoleActuator;
  p.auto_increment = core::AutoIncrement::kBit;
  p.ai_reg = 0x00;  // MODE1
  p.ai_bit = 5;     // AI
  p.doc = "NXP PCA9685 16-channel 12-bit PWM controller (servo HATs, motor HATs)";
  // Datasheet reset values that are not 0.
  p.power_on = {{0x00, 0x11}, {0x01, 0x04}, {0x02, 0xE2}, {0x03, 0xE4},
                {0x04, 0xE8}, {0x05, 0xE0}, {0xFE, 0x1E}};
  for (uint8_t ch = 0; ch < 16; ++ch) {
    p.power_on.push_back({static_cast<uint8_t>(0x09 + 4 * ch), 0x10});  // LEDn_OFF_H: full off
  }
  p.power_on.push_back({0xFD, 0x10});                   // ALL_LED_OFF_H
  p.aliases = {{core::AliasKind::kAddress, 0x70},       // LED All-Call, enabled at power-on
               {core::AliasKind::kGeneralCall, 0x00}};  // general call: SWRST (0x06)

  auto& c = p.commands;
  c.push_back(register_command(
      "mode1", 0x00, 1, 1, 1, kAct,
      {bit_field("restart", 0, 7), bit_field("extclk", 0, 6), bit_field("ai", 0, 5),
       bit_field("sleep", 0, 4), bit_field("sub1", 0, 3), bit_field("sub2", 0, 2),
       bit_field("sub3", 0, 1), bit_field("allcall", 0, 0)},
      "MODE1: restart, external clock, auto-increment, sleep, "
      "sub-address and all-call enables"));
  c.push_back(register_command("mode2", 0x01, 1, 1, 1, kAct,
                               {bit_field("invrt", 0, 4), bit_field("och", 0, 3),
                                bit_field("outdrv", 0, 2), field("outne", 0, 1, 0, 2, false, 0, 3)},
                               "MODE2: output inversion, update on ACK/STOP, driver type"));
  for (uint8_t i = 1; i <= 3; ++i) {
    c.push_back(register_command("subadr" + std::to_string(i), static_cast<uint8_t>(0x01 + i), 1, 1,
                                 1, kAct, {byte_field("addr", 0)},
                                 "I2C sub-address " + std::to_string(i) + " (8-bit form)"));
  }
  c.push_back(register_command("allcalladr", 0x05, 1, 1, 1, kAct, {byte_field("addr", 0)},
                               "LED All-Call address (8-bit form)"));
  c.push_back(register_command("led", 0x06, 4, 16, 4, kAct, led_fields(),
                               "channel n (index) PWM: on/off tick counts and full-on/off bits"));
  c.push_back(
      register_command("all_led", 0xFA, 4, 1, 4, kAct, led_fields(), "all 16 channels at once"));
  c.push_back(register_command(
      "prescale", 0xFE, 1, 1, 1, kAct, {field("prescale", 0, 1, 0, 8, false, 3, 255)},
      "PWM frequency: 25 MHz / (4096 * (prescale + 1)); only while asleep"));
  c.push_back(register_command("testmode", 0xFF, 1, 1, 1, CommandClass::kForbidden,
                               {byte_field("value", 0)}, "TestMode: reserved, never written"));
  // The software reset: one byte 0x06 to the general-call address resets every
  // PCA9685 on the bus to its power-on registers (all outputs off). A command
  // of its own, so a policy can name it (`limit t -> arm.swrst 0 per job`).
  c.push_back(register_command("swrst", 0x06, 0, 0, 0, kAct, {},
                               "SWRST: general call 0x00 then 0x06; every PCA9685 resets"));
  // ALL_LED_* writes load every LEDn register (the shadow must follow, or a
  // fail-safe built from a channel's shadow could carry a stale full-off bit).
  p.broadcast = BroadcastSpec{"all_led", "led"};
  // PRE_SCALE is write-protected while the oscillator runs (datasheet 7.3.5):
  // a write then never reaches the prescaler, and the shadow must not say it did.
  p.gate = GateSpec{"prescale", 4};
  p.read_back = true;  // the Adafruit library reads MODE1 in set_pwm_freq
  // 0x46..0xF9 are reserved: no command covers them, so the core refuses writes there.
  return p;
}

const std::array<ProfileSpec, 3>& profiles() {
  static const std::array<ProfileSpec, 3> kProfiles = {make_gopigo2(), make_line_follower(),
                                                       make_pca9685()};
  return kProfiles;
}

}  // namespace

std::span<const ProfileSpec> builtin_profiles() { return profiles(); }

const ProfileSpec* find_builtin_profile(std::string_view name) {
  for (const ProfileSpec& p : profiles()) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

}  // namespace contego::devices
