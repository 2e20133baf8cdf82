// The verifier: every LoadStatus it can produce, one test each, plus the
// bit-flip and truncation sweeps of a valid image.
#include <algorithm>
#include <gtest/gtest.h>
#include <random>

#include "core/internal.h"
#include "core/test_fixtures.h"

namespace contego::core {
namespace {

using testing::Harness;
using testing::Prog;
namespace rover = testing::rover;

// Recomputes the checksum after a raw edit, so the test reaches the check it targets.
void reseal(std::vector<uint8_t>& b) {
  const uint32_t crc = internal::crc32(b.data() + 16, b.size() - 16);
  std::memcpy(b.data() + 12, &crc, 4);
}

// Byte offset of the section table entry for `kind`.
size_t entry_of(const std::vector<uint8_t>& b, SectionKind kind) {
  uint32_t count = 0;
  std::memcpy(&count, b.data() + 16, 4);
  for (uint32_t i = 0; i < count; ++i) {
    uint32_t k = 0;
    std::memcpy(&k, b.data() + 32 + 16 * i, 4);
    if (k == static_cast<uint32_t>(kind)) return 32 + 16 * i;
  }
  ADD_FAILURE() << "no section " << static_cast<uint32_t>(kind);
  return 0;
}

uint32_t u32_at(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
void put_u32(std::vector<uint8_t>& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

// Rebuilds a canonical image from `b` without the section of kind `drop`.
std::vector<uint8_t> without_section(const std::vector<uint8_t>& b, SectionKind drop) {
  std::vector<SectionEntry> entries;
  std::vector<std::vector<uint8_t>> payloads;
  for (uint32_t i = 0; i < u32_at(b, 16); ++i) {
    SectionEntry e{};
    std::memcpy(&e, b.data() + 32 + 16 * i, sizeof(e));
    if (e.kind == static_cast<uint32_t>(drop)) continue;
    entries.push_back(e);
    payloads.emplace_back(b.begin() + e.offset, b.begin() + e.offset + e.size);
  }
  uint32_t at = 32 + 16 * static_cast<uint32_t>(entries.size());
  for (size_t i = 0; i < entries.size(); ++i) {
    at = (at + 3u) & ~3u;
    entries[i].offset = at;
    at += entries[i].size;
  }
  std::vector<uint8_t> out((at + 3u) & ~3u, 0);
  std::memcpy(out.data(), b.data(), 32);
  put_u32(out, 8, static_cast<uint32_t>(out.size()));
  put_u32(out, 16, static_cast<uint32_t>(entries.size()));
  for (size_t i = 0; i < entries.size(); ++i) {
    std::memcpy(out.data() + 32 + 16 * i, &entries[i], sizeof(SectionEntry));
    if (!payloads[i].empty()) {
      std::memcpy(out.data() + entries[i].offset, payloads[i].data(), payloads[i].size());
    }
  }
  reseal(out);
  return out;
}

class VerifierTest : public ::testing::Test {
 protected:
  LoadResult load_bytes(const std::vector<uint8_t>& b) {
    return h.checker->load(b.data(), static_cast<uint32_t>(b.size()));
  }
  LoadStatus load_model(const image::ImageModel& m) { return h.load(m).status; }
  // The status of the rover model after `edit`.
  LoadStatus load_rover_with(void (*edit)(image::ImageModel&)) {
    image::ImageModel m = rover::model();
    edit(m);
    return load_model(m);
  }
  // Replaces invariant 0's program with `p`.
  LoadResult load_with_program(const Prog& p) {
    image::ImageModel m = rover::model();
    m.invariants[0].record.code_first = testing::add_code(m, p);
    m.invariants[0].record.code_len = static_cast<uint16_t>(p.size());
    return h.load(m);
  }
  Harness h;
  std::vector<uint8_t> valid = image::serialize(rover::model());
};

TEST_F(VerifierTest, AcceptsTheRoverAndArmImages) {
  EXPECT_EQ(load_model(rover::model()), LoadStatus::kOk);
  EXPECT_TRUE(h.checker->loaded());
  EXPECT_EQ(load_model(testing::arm::model()), LoadStatus::kOk);
}

TEST_F(VerifierTest, TooSmall) {
  std::vector<uint8_t> b(valid.begin(), valid.begin() + 31);
  EXPECT_EQ(load_bytes(b).status, LoadStatus::kTooSmall);
  EXPECT_EQ(h.checker->load(nullptr, 0).status, LoadStatus::kTooSmall);
}

TEST_F(VerifierTest, BadMagic) {
  valid[0] ^= 0x01;
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kBadMagic);
}

TEST_F(VerifierTest, BadVersionMajorIsRefusedNewerMinorAccepted) {
  std::vector<uint8_t> minor = valid;
  minor[6] = 7;  // version_minor
  reseal(minor);
  EXPECT_EQ(load_bytes(minor).status, LoadStatus::kOk);
  std::vector<uint8_t> old_major = valid;
  old_major[4] = 1;  // a 1.0 image: byte 3 of a template meant padding, now a channel
  EXPECT_EQ(load_bytes(old_major).status, LoadStatus::kBadVersion);
  valid[4] = 3;  // version_major
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kBadVersion);
}

TEST_F(VerifierTest, SizeMismatch) {
  valid.insert(valid.end(), {0, 0, 0, 0});
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kSizeMismatch);
}

TEST_F(VerifierTest, BadChecksum) {
  valid[valid.size() - 1] ^= 0x80;
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kBadChecksum);
}

TEST_F(VerifierTest, BadHeaderFlags) {
  put_u32(valid, 20, 1);  // flags
  reseal(valid);
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kBadHeader);
}

TEST_F(VerifierTest, SectionBoundsMisalignedAndOverlapping) {
  std::vector<uint8_t> b = valid;
  const size_t e = entry_of(b, SectionKind::kDevices);
  put_u32(b, e + 4, u32_at(b, e + 4) + 2);  // misaligned
  reseal(b);
  LoadResult r = load_bytes(b);
  EXPECT_EQ(r.status, LoadStatus::kSectionBounds);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kDevices));

  b = valid;
  put_u32(b, e + 4, u32_at(b, entry_of(b, SectionKind::kTasks) + 4));  // on top of TASKS
  reseal(b);
  EXPECT_EQ(load_bytes(b).status, LoadStatus::kSectionBounds);

  b = valid;
  put_u32(b, e + 8, 0x7FFFFFF0u);  // size far past the end
  reseal(b);
  EXPECT_EQ(load_bytes(b).status, LoadStatus::kSectionBounds);

  b = valid;  // trailing bytes after the last section
  b.insert(b.end(), {0, 0, 0, 0});
  put_u32(b, 8, static_cast<uint32_t>(b.size()));
  reseal(b);
  EXPECT_EQ(load_bytes(b).status, LoadStatus::kSectionBounds);
}

TEST_F(VerifierTest, RebuiltCanonicalImageIsAccepted) {
  // The helper used by MissingSection produces images the verifier accepts.
  EXPECT_EQ(load_bytes(without_section(valid, static_cast<SectionKind>(0x7777))).status,
            LoadStatus::kOk);
}

TEST_F(VerifierTest, DuplicateSection) {
  put_u32(valid, entry_of(valid, SectionKind::kAliases),
          static_cast<uint32_t>(SectionKind::kTasks));
  reseal(valid);
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kDuplicateSection);
}

TEST_F(VerifierTest, UnknownSection) {
  put_u32(valid, entry_of(valid, SectionKind::kAliases), 99);
  reseal(valid);
  const LoadResult r = load_bytes(valid);
  EXPECT_EQ(r.status, LoadStatus::kUnknownSection);
  EXPECT_EQ(r.section, 99u);
}

TEST_F(VerifierTest, MissingSection) {
  const LoadResult r = load_bytes(without_section(valid, SectionKind::kNames));
  EXPECT_EQ(r.status, LoadStatus::kMissingSection);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kNames));
}

TEST_F(VerifierTest, RecordSize) {
  const size_t e = entry_of(valid, SectionKind::kTasks);
  put_u32(valid, e + 12, u32_at(valid, e + 12) + 1);  // count no longer matches size
  reseal(valid);
  EXPECT_EQ(load_bytes(valid).status, LoadStatus::kRecordSize);
}

TEST_F(VerifierTest, AccessTableMustHaveOneRecordPerTask) {
  image::ImageModel m = rover::model();
  m.access.pop_back();
  EXPECT_EQ(load_model(m), LoadStatus::kRecordSize);
}

TEST_F(VerifierTest, TooManyTasks) {
  image::ImageModel m = rover::model();
  while (m.tasks.size() <= kMaxTasks) {
    m.tasks.push_back(m.tasks[0]);
    m.access.push_back(AccessRecord{});
  }
  EXPECT_EQ(load_model(m), LoadStatus::kTooMany);
}

TEST_F(VerifierTest, BadTagInDeviceProfileAndPadding) {
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) {
              m.devices[0].record.profile = static_cast<Profile>(7);
            }),
            LoadStatus::kBadTag);
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) { m.devices[0].record.gate_bit = 8; }),
            LoadStatus::kBadTag);
  // A gate on a frame device, or past the device's commands.
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) { m.devices[0].record.gated = 1; }),
            LoadStatus::kBadTag);
  image::ImageModel gated = testing::arm::model();
  gated.devices[0].record.gated = static_cast<uint8_t>(gated.devices[0].record.command_count + 1);
  EXPECT_EQ(load_model(gated), LoadStatus::kBadTag);
  gated.devices[0].record.gated = testing::arm::kPrescale + 1;
  EXPECT_EQ(load_model(gated), LoadStatus::kOk);
  image::ImageModel m = rover::model();
  m.invariants[1].record.response = static_cast<Response>(9);
  const LoadResult r = h.load(m);
  EXPECT_EQ(r.status, LoadStatus::kBadTag);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kInvariants));
  EXPECT_EQ(r.index, 1u);
}

TEST_F(VerifierTest, BadReferences) {
  image::ImageModel m = rover::model();
  m.rates[0].record.task = 99;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m = rover::model();  // signal on an actuator
  m.signals[0].record.device = rover::kGopigo;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m = rover::model();  // invariant mask names the sensor's command
  m.invariants[0].record.commands = testing::mask_of({rover::kReadRequest});
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m = rover::model();  // access bit for a device that does not exist
  m.access[0].actuate_devices |= 1u << 5;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m = rover::model();  // template sets a field the command lacks
  m.templates[rover::kTplStop].set_mask = 1;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m = rover::model();  // command range of a device outside COMMANDS
  m.devices[1].record.command_count = 5;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
}

TEST_F(VerifierTest, TemplateChannelsAreBoundedAndSafeStatesNameTheirs) {
  image::ImageModel m = testing::arm::model();
  m.templates[testing::arm::kTplCentre].index = 3;  // kNone: the checked command has its own
  EXPECT_EQ(load_model(m), LoadStatus::kBadField);
  m = testing::arm::model();  // MODE1 has one "channel", 0
  m.templates[testing::arm::kTplSafe].index = 1;
  EXPECT_EQ(load_model(m), LoadStatus::kBadField);
  m = testing::arm::model();  // a safe state is written with nothing checked: name the channel
  m.templates[testing::arm::kTplSafe].index = kSameIndex;
  const LoadResult r = h.load(m);
  EXPECT_EQ(r.status, LoadStatus::kBadField);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kDevices));
  m = rover::model();  // frame commands have no channel
  m.templates[rover::kTplStop].index = 0;
  EXPECT_EQ(load_model(m), LoadStatus::kBadField);
}

TEST_F(VerifierTest, BroadcastAndGeneralCallCommandsAreCrossChecked) {
  image::ImageModel m = testing::arm::model();
  m.devices[0].record.broadcast = testing::arm::kAllLed;
  m.devices[0].record.broadcast_target = testing::arm::kLed;
  EXPECT_EQ(load_model(m), LoadStatus::kOk);
  m.devices[0].record.broadcast_target = 9;  // outside the device's commands
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  m.devices[0].record.broadcast = testing::arm::kLed;  // a repeated group cannot broadcast
  m.devices[0].record.broadcast_target = testing::arm::kAllLed;
  EXPECT_EQ(load_model(m), LoadStatus::kBadField);
  m = rover::model();  // frames have no shadow to broadcast into
  m.devices[0].record.broadcast = 1;
  EXPECT_EQ(load_model(m), LoadStatus::kBadReference);
  // A general-call command (group_len 0) needs no fields and a general-call alias.
  m = testing::arm::model();
  m.commands[testing::arm::kTestMode].record.group_len = 0;
  m.commands[testing::arm::kTestMode].record.repeat = 0;
  m.commands[testing::arm::kTestMode].record.stride = 0;
  m.commands[testing::arm::kTestMode].record.field_count = 0;
  EXPECT_EQ(load_model(m), LoadStatus::kOk);
  image::ImageModel no_alias = m;
  no_alias.aliases.erase(
      std::remove_if(no_alias.aliases.begin(), no_alias.aliases.end(),
                     [](const AliasRecord& a) { return a.kind == AliasKind::kGeneralCall; }),
      no_alias.aliases.end());
  EXPECT_EQ(load_model(no_alias), LoadStatus::kBadReference);
  m.commands[testing::arm::kTestMode].record.stride = 4;  // a general-call command has no group
  EXPECT_EQ(load_model(m), LoadStatus::kBadField);
}

TEST_F(VerifierTest, BadFieldGeometry) {
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) { m.fields[0].record.width = 0; }),
            LoadStatus::kBadField);
  // Past the 4-byte frame.
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) { m.fields[0].record.offset = 4; }),
            LoadStatus::kBadField);
  // 2 bytes from 9 leave the 10-byte sample.
  EXPECT_EQ(load_rover_with([](image::ImageModel& m) { m.signals[4].record.field.offset = 9; }),
            LoadStatus::kBadField);
}

TEST_F(VerifierTest, BadProgramOpcodeAndOperand) {
  Prog p;
  p.op(static_cast<Op>(200)).op(Op::kPass);
  LoadResult r = load_with_program(p);
  EXPECT_EQ(r.status, LoadStatus::kBadProgram);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kCode));
  Prog q;
  q.op(Op::kPushConst, 3).op(Op::kDrop).op(Op::kPass);  // no constants in the image
  EXPECT_EQ(load_with_program(q).status, LoadStatus::kBadProgram);
  Prog ret;  // kReturn is for derived signals only
  ret.push(1).op(Op::kReturn);
  EXPECT_EQ(load_with_program(ret).status, LoadStatus::kBadProgram);
}

// The loader's own superinstructions (state.h, Fused) carry a jump the
// verifier never checks: an image must not be able to hold one.
TEST_F(VerifierTest, TheLoadersFusedOpcodesAreRefusedInAnImage) {
  for (uint32_t op = 0xD0; op <= 0xF5; ++op) {
    Prog p;
    p.push(1).op(static_cast<Op>(op), 1, 0).op(Op::kPass);
    EXPECT_EQ(load_with_program(p).status, LoadStatus::kBadProgram) << op;
  }
}

TEST_F(VerifierTest, JumpBackward) {
  Prog p;
  p.push(1).op(Op::kJumpIfZero, 0, 0).op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kJumpBackward);
}

TEST_F(VerifierTest, JumpOutOfRange) {
  Prog p;
  p.op(Op::kJump, 0, 2).op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kJumpOutOfRange);
}

TEST_F(VerifierTest, ProgramTooLong) {
  Prog p;
  for (uint32_t i = 0; i < kMaxProgramLength; ++i) p.op(Op::kNop);
  p.op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kProgramTooLong);
}

TEST_F(VerifierTest, StackUnderflow) {
  Prog p;
  p.push(1).op(Op::kAdd).op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kStackUnderflow);
}

TEST_F(VerifierTest, StackOverflow) {
  Prog p;
  for (uint32_t i = 0; i <= kMaxStackDepth; ++i) p.push(1);
  p.op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kStackOverflow);
}

TEST_F(VerifierTest, StackMismatchAtJoin) {
  Prog p;
  p.push(1);
  const size_t j = p.jump(Op::kJumpIfZero);
  p.push(5);
  p.land(j).op(Op::kPass);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kStackMismatch);
}

TEST_F(VerifierTest, NoTerminator) {
  Prog p;
  p.push(1).op(Op::kDrop);
  EXPECT_EQ(load_with_program(p).status, LoadStatus::kNoTerminator);
}

TEST_F(VerifierTest, DerivedSignalMayLoadOnlyLowerIdsAndMustReturnOneValue) {
  image::ImageModel m = rover::model();
  Prog self;
  self.signal(rover::kPos).op(Op::kReturn);
  m.signals[rover::kPos].record.code_first = testing::add_code(m, self);
  m.signals[rover::kPos].record.code_len = static_cast<uint16_t>(self.size());
  EXPECT_EQ(load_model(m), LoadStatus::kBadProgram);
  m = rover::model();
  Prog two;
  two.push(1).push(2).op(Op::kReturn);
  m.signals[rover::kPos].record.code_first = testing::add_code(m, two);
  m.signals[rover::kPos].record.code_len = static_cast<uint16_t>(two.size());
  EXPECT_EQ(load_model(m), LoadStatus::kStackMismatch);
}

TEST_F(VerifierTest, BadName) {
  const size_t tasks = u32_at(valid, entry_of(valid, SectionKind::kTasks) + 4);
  put_u32(valid, tasks + offsetof(TaskRecord, name), 0xFFFFu);
  reseal(valid);
  const LoadResult r = load_bytes(valid);
  EXPECT_EQ(r.status, LoadStatus::kBadName);
  EXPECT_EQ(r.section, static_cast<uint32_t>(SectionKind::kTasks));
}

TEST_F(VerifierTest, RefusedImageDiscardsThePreviousPolicy) {
  ASSERT_EQ(load_model(rover::model()), LoadStatus::kOk);
  valid[40] ^= 0xFF;
  EXPECT_NE(load_bytes(valid).status, LoadStatus::kOk);
  EXPECT_FALSE(h.checker->loaded());
  const Verdict v = h.check(rover::kFollower, 0x08, {120, 0, 0, 0});
  EXPECT_EQ(v.decision, Decision::kReject);
  EXPECT_EQ(v.reason, Reason::kNotLoaded);
}

TEST_F(VerifierTest, WorstCaseCostCountsInvariantsAndTheDerivedSignalsTheyUse) {
  ASSERT_EQ(load_model(rover::model()), LoadStatus::kOk);
  const image::ImageModel m = rover::model();
  uint32_t expected = m.signals[rover::kPos].record.code_len;
  for (const auto& inv : m.invariants) expected += inv.record.code_len;
  EXPECT_EQ(h.checker->worst_case_cost(), expected);
}

TEST_F(VerifierTest, StatusNamesAreStable) {
  EXPECT_STREQ(load_status_name(LoadStatus::kBadChecksum), "bad-checksum");
  EXPECT_STREQ(load_status_name(LoadStatus::kBadName), "bad-name");
  EXPECT_STREQ(reason_name(Reason::kRateExceeded), "rate-exceeded");
  EXPECT_STREQ(decision_name(Decision::kFailsafe), "failsafe");
}

// Corruption: every single-bit flip of a valid image is refused (the CRC
// catches all of them, including flips inside NAMES, which the core
// bounds-checks but never reads) and nothing crashes. The only exception is
// version_minor, outside the checksum, where a newer minor is accepted.
TEST_F(VerifierTest, EveryBitFlipIsRefused) {
  for (size_t bit = 0; bit < valid.size() * 8; ++bit) {
    if (bit / 8 == 6 || bit / 8 == 7) continue;  // version_minor: newer minors are accepted
    std::vector<uint8_t> b = valid;
    b[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    EXPECT_NE(load_bytes(b).status, LoadStatus::kOk) << "flip of bit " << bit;
  }
}

// With the checksum recomputed, a flip inside the NAMES payload that keeps
// the strings terminated is accepted; structural flips elsewhere are caught
// by the structural checks (a sample of header and table bits).
TEST_F(VerifierTest, ResealedFlipsInNamesAreAcceptedStructuralFlipsRefused) {
  const size_t names = entry_of(valid, SectionKind::kNames);
  const uint32_t names_at = u32_at(valid, names + 4);
  const uint32_t names_size = u32_at(valid, names + 8);
  for (uint32_t byte = names_at; byte < names_at + names_size; ++byte) {
    if (valid[byte] == 0) continue;  // a terminator: flipping it may unterminate a name
    std::vector<uint8_t> b = valid;
    b[byte] ^= 0x01;
    reseal(b);
    EXPECT_EQ(load_bytes(b).status, LoadStatus::kOk) << "names byte " << byte;
  }
  // Header (magic, version, size, count, flags, reserved) and section table.
  const uint32_t table_end = 32 + 16 * u32_at(valid, 16);
  for (size_t bit = 0; bit < table_end * 8; ++bit) {
    const size_t byte = bit / 8;
    if (byte >= 6 && byte < 8) continue;    // version_minor: newer minors are accepted
    if (byte >= 12 && byte < 16) continue;  // the checksum itself (recomputed)
    std::vector<uint8_t> b = valid;
    b[byte] ^= static_cast<uint8_t>(1u << (bit % 8));
    reseal(b);
    EXPECT_NE(load_bytes(b).status, LoadStatus::kOk) << "header/table bit " << bit;
  }
}

TEST_F(VerifierTest, EveryTruncationIsRefused) {
  for (size_t len = 0; len < valid.size(); ++len) {
    std::vector<uint8_t> b(valid.begin(), valid.begin() + static_cast<ptrdiff_t>(len));
    EXPECT_NE(h.checker->load(b.data(), static_cast<uint32_t>(b.size())).status, LoadStatus::kOk)
        << "length " << len;
  }
}

// Random structural damage with a valid checksum: the verifier must refuse
// or accept without crashing, and a check() after an accepted one must not
// crash either (ASan/UBSan builds make this meaningful).
TEST_F(VerifierTest, ResealedRandomFlipsNeverCrash) {
  std::mt19937 rng(12345);
  const std::vector<uint8_t> arm = image::serialize(testing::arm::model());
  for (int i = 0; i < 3000; ++i) {
    std::vector<uint8_t> b = (i % 2) ? valid : arm;
    const int flips = 1 + static_cast<int>(rng() % 3);
    for (int k = 0; k < flips; ++k) {
      const size_t bit = rng() % (b.size() * 8);
      b[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
    }
    reseal(b);
    if (load_bytes(b).status == LoadStatus::kOk) {
      h.samples[rover::kLine].bytes = testing::rover::sample(testing::rover::kCentre);
      (void)h.check(0, 0x08, {1, 119, 0, 0, 0});
      (void)h.check(0, 0x40, {0x06, 1, 2, 3, 4});
    }
  }
}

}  // namespace
}  // namespace contego::core
