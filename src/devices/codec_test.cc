// Every documented byte sequence of the device facts decodes as expected, and
// every command of every built-in profile survives an encode/decode round trip.
#include "devices/codec.h"

#include <gtest/gtest.h>

#include "devices/profile.h"

namespace contego::devices {
namespace {

const ProfileSpec& gopigo() { return *find_builtin_profile("gopigo2"); }
const ProfileSpec& line() { return *find_builtin_profile("line_follower"); }
const ProfileSpec& pca() { return *find_builtin_profile("pca9685"); }

std::string decode(const ProfileSpec& p, std::vector<uint8_t> bytes) {
  Result<std::string> r = describe(p, bytes);
  return r.ok() ? *r : "error: " + r.error();
}

// Feeds a sequence of writes to one decoder and describes everything completed.
std::vector<std::string> decode_all(HostDecoder& d, std::vector<std::vector<uint8_t>> writes) {
  std::vector<std::string> out;
  for (const auto& w : writes) {
    auto r = d.write(w);
    if (!r) {
      out.push_back("error: " + r.error());
      continue;
    }
    for (const DecodedCommand& c : *r) out.push_back(describe(c));
  }
  return out;
}

TEST(GopigoDecode, CLibraryFiveByteFrames) {
  EXPECT_EQ(decode(gopigo(), {0x01, 0x46, 0x55, 0x00, 0x00}), "set_left_speed(speed=85)");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x47, 0x7D, 0x00, 0x00}), "set_right_speed(speed=125)");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x64, 0x00, 0x00, 0x00}), "right()");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x61, 0x00, 0x00, 0x00}), "left()");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x77, 0x00, 0x00, 0x00}), "fwd_pid()");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x78, 0x00, 0x00, 0x00}), "stop()");
}

TEST(GopigoDecode, FourByteFramesWithoutTheRegisterByte) {
  EXPECT_EQ(decode(gopigo(), {0x69, 0x00, 0x00, 0x00}), "fwd()");
  EXPECT_EQ(decode(gopigo(), {0x6F, 0x01, 0xC8, 0x00}), "motor1(dir=1, speed=200)");
  // The prefix byte is ignored whatever its value: the device acts on the last 4 bytes.
  EXPECT_EQ(decode(gopigo(), {0xAA, 0x46, 0x50, 0x00, 0x00}), "set_left_speed(speed=80)");
}

TEST(GopigoDecode, BigEndianSixteenBitValues) {
  // enc_tgt(m1=1, m2=1, n=300): (1*2+1), 300>>8, 300&0xFF.
  EXPECT_EQ(decode(gopigo(), {0x01, 0x32, 0x03, 0x01, 0x2C}), "enc_tgt(motors=3, ticks=300)");
  // enable_com_timeout(1000 ms): 1000>>8 = 3, 1000&0xFF = 0xE8.
  EXPECT_EQ(decode(gopigo(), {0x01, 0x50, 0x03, 0xE8, 0x00}), "enable_com_timeout(timeout=1000)");
}

TEST(GopigoDecode, MalformedLengthsAndUnknownOpcodesAreErrors) {
  EXPECT_EQ(decode(gopigo(), {0x01, 0x46, 0x55}),
            "error: gopigo2: malformed write of 3 bytes (frames are 4 or 5 with prefix)");
  EXPECT_NE(decode(gopigo(), {0x01, 0x46, 0x55, 0, 0, 0}).find("malformed write of 6"),
            std::string::npos);
  EXPECT_EQ(decode(gopigo(), {0x01, 0xFE, 0x00, 0x00, 0x00}),
            "error: gopigo2: unknown opcode 254 (0xfe)");
  EXPECT_EQ(decode(gopigo(), {0x01, 0x0A, 0x00, 0x00, 0x00}), "factory_test1()");
}

TEST(LineFollowerDecode, ReadRequestIsTheQueryCommand) {
  EXPECT_EQ(decode(line(), {0x01, 0x03, 0x00, 0x00, 0x00}), "read_sensors()");
}

// DI's driver probes with a one-byte write of the board-name query; the host
// decoder agrees with the core (decode.cc): a single byte is a query or malformed.
TEST(LineFollowerDecode, OneByteQueryWritesAreTheQuery) {
  EXPECT_EQ(decode(line(), {0x12}), "board_name()");
  EXPECT_EQ(decode(line(), {0x03}), "read_sensors()");
  EXPECT_EQ(decode(line(), {0x44}),
            "error: line_follower: malformed one-byte write 0x44 (not a query)");
  // Profiles without one-byte queries keep refusing a single byte.
  EXPECT_NE(decode(gopigo(), {0x08}).find("malformed write of 1"), std::string::npos);
}

TEST(LineFollowerSample, EncodesFiveBigEndianReadings) {
  std::vector<FieldValue> v = {
      {"raw0", 767}, {"raw1", 815}, {"raw2", 1015}, {"raw3", 710}, {"raw4", 1004}};
  Result<std::vector<uint8_t>> s = encode_sample(line(), v);
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(*s, (std::vector<uint8_t>{0x02, 0xFF, 0x03, 0x2F, 0x03, 0xF7, 0x02, 0xC6, 0x03, 0xEC}));
  std::vector<FieldValue> bad = {{"raw0", 1024}};
  EXPECT_FALSE(encode_sample(line(), bad).ok());
}

TEST(Pca9685Decode, AdafruitArmTraceByteWise) {
  // tutRPi 6DOF example.py through Adafruit_PCA9685 (PureIO backend): init,
  // set_pwm_freq(60), hand open (ch5 <- 420), hand close (ch5 <- 577).
  HostDecoder d(pca());
  std::vector<std::string> got = decode_all(d, {{0xFA, 0x00},
                                                {0xFB, 0x00},
                                                {0xFC, 0x00},
                                                {0xFD, 0x00},
                                                {0x01, 0x04},
                                                {0x00, 0x01},
                                                {0x00, 0x01},
                                                {0x00, 0x11},
                                                {0xFE, 0x65},
                                                {0x00, 0x01},
                                                {0x00, 0x81},
                                                {0x1A, 0x00},
                                                {0x1B, 0x00},
                                                {0x1C, 0xA4},
                                                {0x1D, 0x01},
                                                {0x1A, 0x00},
                                                {0x1B, 0x00},
                                                {0x1C, 0x41},
                                                {0x1D, 0x02}});
  auto m1 = [&](int restart, int sleep) {
    return "mode1(restart=" + std::to_string(restart) +
           ", extclk=0, ai=0, sleep=" + std::to_string(sleep) +
           ", sub1=0, sub2=0, sub3=0, allcall=1)";
  };
  std::vector<std::string> want = {"all_led(on=0, off=0, full_on=0, full_off=0)",
                                   "mode2(invrt=0, och=0, outdrv=1, outne=0)",
                                   m1(0, 0),
                                   m1(0, 0),
                                   m1(0, 1),
                                   "prescale(prescale=101)",
                                   m1(0, 0),
                                   m1(1, 0),
                                   "led(5, on=0, off=420, full_on=0, full_off=0)",
                                   "led(5, on=0, off=577, full_on=0, full_off=0)"};
  EXPECT_EQ(got, want);
  EXPECT_EQ(d.reg(0xFE), 0x65);
  EXPECT_EQ(d.reg(0x1D), 0x02);
}

TEST(Pca9685Decode, AutoIncrementBlockWriteNeedsMode1Ai) {
  HostDecoder d(pca());
  // Power-on MODE1 = 0x11: AI off, so all four data bytes land in LED5_ON_L
  // and the group never completes.
  EXPECT_EQ(decode_all(d, {{0x1A, 0x00, 0x00, 0x41, 0x02}}), std::vector<std::string>{});
  // CircuitPython sets RESTART|AI, then writes a channel as one 5-byte block.
  std::vector<std::string> got = decode_all(d, {{0x00, 0xA1}, {0x1A, 0x00, 0x00, 0x41, 0x02}});
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[1], "led(5, on=0, off=577, full_on=0, full_off=0)");
}

TEST(Pca9685Decode, WordWriteOfOffRegistersReassemblesThePulse) {
  HostDecoder d(pca());
  ASSERT_TRUE(d.write(std::vector<uint8_t>{0x00, 0x21}).ok());  // AI on
  // SMBus WORD_DATA at LED5_OFF_L: [cmd, lo, hi]; ON keeps its power-on 0.
  EXPECT_EQ(decode_all(d, {{0x1C, 0xA4, 0x01}}),
            std::vector<std::string>{"led(5, on=0, off=420, full_on=0, full_off=0)"});
}

TEST(Pca9685Decode, FullOnAndFullOffBits) {
  // CircuitPython full-on = (0x1000, 0): ON_H bit 4. Power-on OFF_H is 0x10 (full off).
  HostDecoder d(pca());
  ASSERT_TRUE(d.write(std::vector<uint8_t>{0x00, 0x21}).ok());
  EXPECT_EQ(decode_all(d, {{0x06, 0x00, 0x10, 0x00, 0x00}}),
            std::vector<std::string>{"led(0, on=0, off=0, full_on=1, full_off=0)"});
  // Byte-wise OFF_H alone completes the group with the shadow values (power-on full off).
  HostDecoder fresh(pca());
  EXPECT_EQ(decode_all(fresh, {{0x0D, 0x10}}),
            std::vector<std::string>{"led(1, on=0, off=0, full_on=0, full_off=1)"});
}

TEST(Pca9685Decode, ReservedRegistersAndTestModeAndPointerWrites) {
  EXPECT_EQ(decode(pca(), {0x46, 0x00}),
            "error: pca9685: register 0x46 is not covered by the profile");
  EXPECT_EQ(decode(pca(), {0xF9, 0x00}),
            "error: pca9685: register 0xf9 is not covered by the profile");
  EXPECT_EQ(decode(pca(), {0xFF, 0x01}), "testmode(value=1)");
  EXPECT_EQ(decode(pca(), {0x06}), "(no command)");  // register pointer only (before a read)
  EXPECT_EQ(decode(pca(), {0xFE, 0x03}), "prescale(prescale=3)");
}

TEST(Encode, GopigoWithAndWithoutPrefix) {
  std::vector<FieldValue> v = {{"speed", 85}};
  auto w = encode_command(gopigo(), "set_left_speed", v);
  ASSERT_TRUE(w.ok()) << w.error();
  EXPECT_EQ(*w, (std::vector<std::vector<uint8_t>>{{0x01, 0x46, 0x55, 0x00, 0x00}}));
  EncodeOptions bare;
  bare.with_prefix = false;
  w = encode_command(gopigo(), "set_left_speed", v, bare);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(*w, (std::vector<std::vector<uint8_t>>{{0x46, 0x55, 0x00, 0x00}}));
}

TEST(Encode, ErrorsNameCommandFieldAndRange) {
  std::vector<FieldValue> v = {{"speed", 300}};
  auto w = encode_command(gopigo(), "set_left_speed", v);
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error(), "gopigo2.set_left_speed field 'speed': value 300 outside 0..255");
  std::vector<FieldValue> wrong = {{"sped", 1}};
  w = encode_command(gopigo(), "set_left_speed", wrong);
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error(), "gopigo2.set_left_speed has no field 'sped' (fields: speed)");
  EXPECT_EQ(encode_command(gopigo(), "warp", {}).error(),
            "profile 'gopigo2' has no command 'warp'");
  EncodeOptions ch16;
  ch16.index = 16;
  EXPECT_FALSE(encode_command(pca(), "led", {}, ch16).ok());
}

TEST(Encode, Pca9685BlockAndPerRegisterWrites) {
  std::vector<FieldValue> v = {{"on", 0}, {"off", 577}};
  EncodeOptions o;
  o.index = 5;
  auto block = encode_command(pca(), "led", v, o);
  ASSERT_TRUE(block.ok()) << block.error();
  EXPECT_EQ(*block, (std::vector<std::vector<uint8_t>>{{0x1A, 0x00, 0x00, 0x41, 0x02}}));
  o.per_register = true;
  auto bytes = encode_command(pca(), "led", v, o);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(*bytes, (std::vector<std::vector<uint8_t>>{
                        {0x1A, 0x00}, {0x1B, 0x00}, {0x1C, 0x41}, {0x1D, 0x02}}));
  std::vector<FieldValue> sleep = {{"sleep", 1}, {"allcall", 1}};
  auto m = encode_command(pca(), "mode1", sleep);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(*m, (std::vector<std::vector<uint8_t>>{{0x00, 0x11}}));
}

// Sets every field of `c` to a value inside its range that is not trivially 0.
std::vector<FieldValue> sample_values(const CommandSpec& c) {
  std::vector<FieldValue> v;
  for (const FieldSpec& f : c.fields) v.push_back({f.name, f.max - (f.max - f.min) / 3});
  return v;
}

TEST(Encode, EveryBuiltinCommandRoundTrips) {
  for (const ProfileSpec& p : builtin_profiles()) {
    for (const CommandSpec& c : p.commands) {
      std::vector<FieldValue> v = sample_values(c);
      if (p.kind == core::Profile::kRegisterMap && c.group_len == 0) {
        // A general-call command (PCA9685 swrst) goes to address 0, not to
        // the device: encoding it for the device is refused, naming the byte.
        auto refused = encode_command(p, c.name, v, EncodeOptions{});
        ASSERT_FALSE(refused.ok());
        EXPECT_NE(refused.error().find("general-call"), std::string::npos) << refused.error();
        continue;
      }
      EncodeOptions o;
      o.index = c.repeat > 1 ? c.repeat - 1u : 0u;
      o.per_register = true;  // works whatever the auto-increment state
      auto writes = encode_command(p, c.name, v, o);
      ASSERT_TRUE(writes.ok()) << p.name << "." << c.name << ": " << writes.error();
      HostDecoder d(p);
      std::vector<DecodedCommand> got;
      for (const auto& w : *writes) {
        auto r = d.write(w);
        ASSERT_TRUE(r.ok()) << p.name << "." << c.name << ": " << r.error();
        got.insert(got.end(), r->begin(), r->end());
      }
      ASSERT_EQ(got.size(), 1u) << p.name << "." << c.name;
      EXPECT_EQ(got[0].command, &c) << p.name << "." << c.name;
      EXPECT_EQ(got[0].index, o.index) << p.name << "." << c.name;
      for (size_t f = 0; f < v.size(); ++f) {
        EXPECT_EQ(got[0].values[f], v[f].value) << p.name << "." << c.name << "." << v[f].name;
      }
    }
  }
}

TEST(ExtractField, SignedLittleAndBigEndian) {
  core::FieldRecord g{};
  g.offset = 1;
  g.nbytes = 2;
  g.width = 16;
  g.flags = core::kFieldSigned;
  std::vector<uint8_t> b = {0x00, 0xFE, 0xFF};
  EXPECT_EQ(*extract_field(g, b), -2);
  g.flags = core::kFieldSigned | core::kFieldBigEndian;
  EXPECT_EQ(*extract_field(g, b), -257);
  g.offset = 2;
  EXPECT_FALSE(extract_field(g, b).ok());
}

}  // namespace
}  // namespace contego::devices
