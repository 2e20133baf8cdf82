// The image verifier: Checker::load(). Checks everything docs/image-format.md
// promises before a single table is used, in a fixed order, and stops at the
// first problem with (status, section, index). Only then are the tables
// marked loaded: an image is all accepted or all refused.
#include "contego/core/checker.h"

#include "core/internal.h"

namespace contego::core {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the image is little-endian and the core copies records as they are");

constexpr uint32_t kHeaderSize = sizeof(ImageHeader);
constexpr uint32_t kMaxSections = 32;
constexpr uint32_t kKindCount = 14;
constexpr uint32_t kKinds[kKindCount] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 0x100};
constexpr uint32_t kRecordSizes[kKindCount] = {sizeof(TaskRecord),
                                               sizeof(DeviceRecord),
                                               sizeof(AliasRecord),
                                               sizeof(CommandRecord),
                                               sizeof(FieldRecord),
                                               sizeof(SignalRecord),
                                               sizeof(RateRecord),
                                               sizeof(InvariantRecord),
                                               sizeof(TemplateRecord),
                                               sizeof(Insn),
                                               sizeof(int64_t),
                                               sizeof(AccessRecord),
                                               sizeof(RegisterInitRecord),
                                               1};
constexpr uint32_t kMaxCounts[kKindCount] = {kMaxTasks,
                                             kMaxDevices,
                                             kMaxAliases,
                                             kMaxCommandDefs,
                                             kMaxFieldDefs,
                                             kMaxSignals,
                                             kMaxRateLimits,
                                             kMaxInvariants,
                                             kMaxTemplates,
                                             kMaxCodeWords,
                                             kMaxConstants,
                                             kMaxTasks,
                                             kMaxDevices* kMaxRegisters,
                                             kMaxImageBytes};

int kind_slot(uint32_t kind) {
  for (uint32_t i = 0; i < kKindCount; ++i) {
    if (kKinds[i] == kind) return static_cast<int>(i);
  }
  return -1;
}

constexpr int kSlotTasks = 0, kSlotDevices = 1, kSlotAliases = 2, kSlotCommands = 3,
              kSlotFields = 4, kSlotSignals = 5, kSlotRates = 6, kSlotInvariants = 7,
              kSlotTemplates = 8, kSlotCode = 9, kSlotConstants = 10, kSlotAccess = 11,
              kSlotRegisterInit = 12, kSlotNames = 13;

LoadResult fail(LoadStatus status, uint32_t section, uint32_t index) {
  return LoadResult{status, section, index};
}

uint32_t sec(SectionKind k) { return static_cast<uint32_t>(k); }

bool name_ok(const uint8_t* names, uint32_t names_size, uint32_t offset) {
  if (offset >= names_size) return false;
  for (uint32_t i = offset; i < names_size; ++i) {
    if (names[i] == 0) return true;
  }
  return false;
}

// Field geometry: inside `limit` bytes, 1..4 bytes, shift + width within them.
LoadStatus check_field(const FieldRecord& f, uint32_t limit) {
  if ((f.flags & ~(kFieldBigEndian | kFieldSigned)) != 0) return LoadStatus::kBadTag;
  if (f.pad[0] != 0 || f.pad[1] != 0 || f.pad[2] != 0) return LoadStatus::kBadTag;
  if (f.nbytes < 1 || f.nbytes > 4 || f.width < 1 || f.width > 32 || f.shift >= 32) {
    return LoadStatus::kBadField;
  }
  if (static_cast<uint32_t>(f.shift) + f.width > 8u * f.nbytes) return LoadStatus::kBadField;
  if (static_cast<uint32_t>(f.offset) + f.nbytes > limit) return LoadStatus::kBadField;
  return LoadStatus::kOk;
}

bool response_ok(uint8_t r) {
  return r == static_cast<uint8_t>(Response::kIgnore) ||
         r == static_cast<uint8_t>(Response::kFailsafe) ||
         r == static_cast<uint8_t>(Response::kReject);
}

}  // namespace

void Checker::clear_tables() {
  loaded_ = false;
  journal_.active = false;  // a transfer open across a load is forgotten, not undone
  worst_case_cost_ = 0;
  task_count_ = device_count_ = alias_count_ = command_count_ = field_count_ = 0;
  signal_count_ = rate_count_ = invariant_count_ = template_count_ = code_count_ = 0;
  constant_count_ = 0;
  derived_mask_ = 0;
  __builtin_memset(signal_deps_, 0, sizeof(signal_deps_));
  __builtin_memset(signal_devices_, 0, sizeof(signal_devices_));
  __builtin_memset(state_, 0, sizeof(state_));
  __builtin_memset(last_, 0, sizeof(last_));
  __builtin_memset(last_first_, 0, sizeof(last_first_));
  __builtin_memset(signal_memo_, 0, sizeof(signal_memo_));
  __builtin_memset(sample_memo_, 0, sizeof(sample_memo_));
  __builtin_memset(windows_, 0, sizeof(windows_));
  __builtin_memset(job_count_, 0, sizeof(job_count_));
  __builtin_memset(rate_used_, 0, sizeof(rate_used_));
  __builtin_memset(state_words_, 0, sizeof(state_words_));
  epoch_ = 0;
  executed_ = 0;
}

LoadResult Checker::load(const uint8_t* image, uint32_t size) {
  clear_tables();
  LoadResult r = verify(image, size);
  if (r.status != LoadStatus::kOk) {
    clear_tables();
    return r;
  }
  compute_costs();
  loaded_ = true;
  return r;
}

LoadResult Checker::verify(const uint8_t* image, uint32_t size) {
  using S = LoadStatus;
  // --- header ---------------------------------------------------------------
  if (image == nullptr || size < kHeaderSize) return fail(S::kTooSmall, 0, 0);
  ImageHeader h;
  __builtin_memcpy(&h, image, sizeof(h));
  if (h.magic != kImageMagic) return fail(S::kBadMagic, 0, 0);
  if (h.version_major != kImageVersionMajor) return fail(S::kBadVersion, 0, 0);
  if (h.total_size != size || size > kMaxImageBytes) return fail(S::kSizeMismatch, 0, 0);
  if (internal::crc32(image + 16, size - 16) != h.checksum) return fail(S::kBadChecksum, 0, 0);
  if (h.flags != 0 || h.reserved[0] != 0 || h.reserved[1] != 0) return fail(S::kBadHeader, 0, 0);
  if (h.section_count > kMaxSections) return fail(S::kTooMany, 0, 0);
  const uint32_t table_end = kHeaderSize + 16u * h.section_count;
  if (table_end > size) return fail(S::kSectionBounds, 0, 0);

  // --- section table ----------------------------------------------------------
  SectionEntry entries[kMaxSections];
  int slot_of_entry[kMaxSections];
  int entry_of_slot[kKindCount];
  for (uint32_t i = 0; i < kKindCount; ++i) entry_of_slot[i] = -1;
  uint32_t cursor = table_end;
  for (uint32_t i = 0; i < h.section_count; ++i) {
    SectionEntry& e = entries[i];
    __builtin_memcpy(&e, image + kHeaderSize + 16u * i, sizeof(e));
    const int slot = kind_slot(e.kind);
    if (slot < 0) return fail(S::kUnknownSection, e.kind, i);
    if (entry_of_slot[slot] >= 0) return fail(S::kDuplicateSection, e.kind, i);
    entry_of_slot[slot] = static_cast<int>(i);
    slot_of_entry[i] = slot;
    // Canonical layout: payloads follow the table in table order, each at the
    // previous end rounded up to 4, zero padding, nothing after the last one.
    // So every byte of the image is accounted for.
    const uint64_t end = static_cast<uint64_t>(e.offset) + e.size;
    const uint32_t expected = (cursor + 3u) & ~3u;
    if (e.offset != expected || end > size) return fail(S::kSectionBounds, e.kind, i);
    for (uint32_t p = cursor; p < expected; ++p) {
      if (image[p] != 0) return fail(S::kSectionBounds, e.kind, i);
    }
    cursor = static_cast<uint32_t>(end);
  }
  {
    const uint32_t expected_end = (cursor + 3u) & ~3u;
    if (expected_end != size) return fail(S::kSectionBounds, 0, h.section_count);
    for (uint32_t p = cursor; p < size; ++p) {
      if (image[p] != 0) return fail(S::kSectionBounds, 0, h.section_count);
    }
  }
  for (uint32_t s = 0; s < kKindCount; ++s) {
    if (entry_of_slot[s] < 0) return fail(S::kMissingSection, kKinds[s], 0);
  }
  for (uint32_t i = 0; i < h.section_count; ++i) {
    const SectionEntry& e = entries[i];
    const uint32_t slot = static_cast<uint32_t>(slot_of_entry[i]);
    if (static_cast<uint64_t>(e.count) * kRecordSizes[slot] != e.size) {
      return fail(S::kRecordSize, e.kind, 0);
    }
    if (e.count > kMaxCounts[slot]) return fail(S::kTooMany, e.kind, 0);
  }
  auto entry = [&](int slot) -> const SectionEntry& { return entries[entry_of_slot[slot]]; };
  auto copy = [&](int slot, void* dst) {
    const SectionEntry& e = entry(slot);
    if (e.size != 0) __builtin_memcpy(dst, image + e.offset, e.size);
    return e.count;
  };
  task_count_ = copy(kSlotTasks, tasks_);
  device_count_ = copy(kSlotDevices, devices_);
  alias_count_ = copy(kSlotAliases, aliases_);
  command_count_ = copy(kSlotCommands, commands_);
  field_count_ = copy(kSlotFields, fields_);
  signal_count_ = copy(kSlotSignals, signals_);
  rate_count_ = copy(kSlotRates, rates_);
  invariant_count_ = copy(kSlotInvariants, invariants_);
  template_count_ = copy(kSlotTemplates, templates_);
  code_count_ = copy(kSlotCode, code_);
  constant_count_ = copy(kSlotConstants, constants_);
  const uint32_t access_count = copy(kSlotAccess, access_);
  if (access_count != task_count_) return fail(S::kRecordSize, sec(SectionKind::kAccess), 0);
  const SectionEntry& init = entry(kSlotRegisterInit);
  const SectionEntry& names = entry(kSlotNames);
  const uint8_t* name_bytes = image + names.offset;

  // --- names --------------------------------------------------------------------
  for (uint32_t i = 0; i < task_count_; ++i) {
    if (!name_ok(name_bytes, names.size, tasks_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kTasks), i);
    }
  }
  for (uint32_t i = 0; i < device_count_; ++i) {
    if (!name_ok(name_bytes, names.size, devices_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kDevices), i);
    }
  }
  for (uint32_t i = 0; i < command_count_; ++i) {
    if (!name_ok(name_bytes, names.size, commands_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kCommands), i);
    }
  }
  for (uint32_t i = 0; i < field_count_; ++i) {
    if (!name_ok(name_bytes, names.size, fields_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kFields), i);
    }
  }
  for (uint32_t i = 0; i < signal_count_; ++i) {
    if (!name_ok(name_bytes, names.size, signals_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kSignals), i);
    }
  }
  for (uint32_t i = 0; i < rate_count_; ++i) {
    if (!name_ok(name_bytes, names.size, rates_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kRates), i);
    }
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    if (!name_ok(name_bytes, names.size, invariants_[i].name)) {
      return fail(S::kBadName, sec(SectionKind::kInvariants), i);
    }
  }

  // --- devices ------------------------------------------------------------------
  const uint32_t kDevSec = sec(SectionKind::kDevices);
  for (uint32_t i = 0; i < device_count_; ++i) {
    const DeviceRecord& d = devices_[i];
    if (d.role == 0 || (d.role & ~(kRoleActuator | kRoleSensor)) != 0) {
      return fail(S::kBadTag, kDevSec, i);
    }
    if (d.profile != static_cast<uint8_t>(Profile::kFrame) &&
        d.profile != static_cast<uint8_t>(Profile::kRegisterMap)) {
      return fail(S::kBadTag, kDevSec, i);
    }
    if (d.ten_bit > 1 || d.auto_increment > static_cast<uint8_t>(AutoIncrement::kBit) ||
        d.latch_mode > static_cast<uint8_t>(LatchMode::kHoldSafeUnrepaired) ||
        d.short_queries > 1 || d.pad0[0] != 0 || d.pad0[1] != 0 ||
        (d.short_queries != 0 && d.profile != static_cast<uint8_t>(Profile::kFrame))) {
      return fail(S::kBadTag, kDevSec, i);
    }
    if (d.addr > (d.ten_bit ? 0x3FFu : 0x7Fu) || d.ai_bit > 7 ||
        d.sample_request_len > sizeof(d.sample_request) || d.sample_len > kMaxSampleBytes) {
      return fail(S::kBadField, kDevSec, i);
    }
    if (d.profile == static_cast<uint8_t>(Profile::kFrame) &&
        (d.frame_len < 1 || d.prefix_len > 1 ||
         static_cast<uint32_t>(d.frame_len) + d.prefix_len > kMaxWriteBytes)) {
      return fail(S::kBadField, kDevSec, i);
    }
    if (d.latch_mode != static_cast<uint8_t>(LatchMode::kOff) &&
        (d.latch_count < 1 || d.latch_count > kMaxLatchCount)) {
      return fail(S::kBadField, kDevSec, i);
    }
    if (static_cast<uint32_t>(d.command_first) + d.command_count > command_count_) {
      return fail(S::kBadReference, kDevSec, i);
    }
    for (uint32_t c = d.command_first; c < static_cast<uint32_t>(d.command_first) + d.command_count;
         ++c) {
      if (commands_[c].device != i) return fail(S::kBadReference, kDevSec, i);
    }
    if (d.safe_count > kMaxSafeStateCommands) return fail(S::kTooMany, kDevSec, i);
    if (static_cast<uint32_t>(d.safe_first) + d.safe_count > template_count_) {
      return fail(S::kBadReference, kDevSec, i);
    }
    for (uint32_t t = d.safe_first; t < static_cast<uint32_t>(d.safe_first) + d.safe_count; ++t) {
      const uint16_t c = templates_[t].command;
      if (c >= command_count_ || commands_[c].device != i) {
        return fail(S::kBadReference, kDevSec, i);
      }
    }
    for (uint32_t j = 0; j < i; ++j) {
      const DeviceRecord& o = devices_[j];
      if (o.bus == d.bus && o.addr == d.addr && o.ten_bit == d.ten_bit) {
        return fail(S::kBadReference, kDevSec, i);  // two devices at one address
      }
    }
  }

  // --- aliases --------------------------------------------------------------------
  for (uint32_t i = 0; i < alias_count_; ++i) {
    const AliasRecord& a = aliases_[i];
    if (a.kind > static_cast<uint8_t>(AliasKind::kGeneralCall) || a.pad != 0) {
      return fail(S::kBadTag, sec(SectionKind::kAliases), i);
    }
    if (a.device >= device_count_) return fail(S::kBadReference, sec(SectionKind::kAliases), i);
    if (a.addr > 0x7F || (a.kind == static_cast<uint8_t>(AliasKind::kGeneralCall) && a.addr != 0) ||
        (a.kind == static_cast<uint8_t>(AliasKind::kAddress) && a.addr == 0)) {
      return fail(S::kBadField, sec(SectionKind::kAliases), i);
    }
  }

  // --- commands and fields ----------------------------------------------------------
  const uint32_t kCmdSec = sec(SectionKind::kCommands);
  for (uint32_t i = 0; i < command_count_; ++i) {
    const CommandRecord& c = commands_[i];
    if (c.device >= device_count_) return fail(S::kBadReference, kCmdSec, i);
    const DeviceRecord& d = devices_[c.device];
    if (i < d.command_first || i >= static_cast<uint32_t>(d.command_first) + d.command_count) {
      return fail(S::kBadReference, kCmdSec, i);  // not inside its device's range
    }
    if (c.command_class < static_cast<uint8_t>(CommandClass::kActuate) ||
        c.command_class > static_cast<uint8_t>(CommandClass::kForbidden)) {
      return fail(S::kBadTag, kCmdSec, i);
    }
    if (c.field_count > kMaxFieldsPerCommand) return fail(S::kTooMany, kCmdSec, i);
    if (static_cast<uint32_t>(c.field_first) + c.field_count > field_count_) {
      return fail(S::kBadReference, kCmdSec, i);
    }
    uint32_t limit = 0;
    if (d.profile == static_cast<uint8_t>(Profile::kFrame)) {
      if (c.group_len != 0 || c.repeat != 0 || c.stride != 0) return fail(S::kBadField, kCmdSec, i);
      limit = d.frame_len;
    } else if (c.group_len == 0) {
      // A general-call command: one byte, no fields, on a general-call listener.
      if (c.repeat != 0 || c.stride != 0 || c.field_count != 0) {
        return fail(S::kBadField, kCmdSec, i);
      }
      bool listens = false;
      for (uint32_t a = 0; a < alias_count_; ++a) {
        listens = listens || (aliases_[a].device == c.device &&
                              aliases_[a].kind == static_cast<uint8_t>(AliasKind::kGeneralCall));
      }
      if (!listens) return fail(S::kBadReference, kCmdSec, i);
      for (uint32_t k = d.command_first; k < i; ++k) {
        if (commands_[k].group_len == 0 && commands_[k].match == c.match) {
          return fail(S::kBadField, kCmdSec, i);  // two general-call commands, one byte
        }
      }
    } else {
      if (c.group_len < 1 || c.repeat < 1 || (c.repeat > 1 && c.stride < c.group_len)) {
        return fail(S::kBadField, kCmdSec, i);
      }
      const uint32_t last =
          c.match + static_cast<uint32_t>(c.repeat - 1) * c.stride + c.group_len - 1;
      if (last >= kMaxRegisters) return fail(S::kBadField, kCmdSec, i);
      limit = c.group_len;
    }
    for (uint32_t f = c.field_first; f < static_cast<uint32_t>(c.field_first) + c.field_count;
         ++f) {
      const LoadStatus st = check_field(fields_[f], limit);
      if (st != S::kOk) return fail(st, sec(SectionKind::kFields), f);
    }
  }
  // Per-device lookup tables: opcode (frame) or register (map) -> command. Two
  // commands claiming one opcode or register make decoding ambiguous.
  for (uint32_t dv = 0; dv < device_count_; ++dv) {
    uint8_t* lookup = state_[dv].lookup;
    __builtin_memset(lookup, 0xFF, kMaxRegisters);
    const DeviceRecord& d = devices_[dv];
    for (uint32_t k = 0; k < d.command_count; ++k) {
      const uint32_t ci = d.command_first + k;
      const CommandRecord& c = commands_[ci];
      if (d.profile == static_cast<uint8_t>(Profile::kFrame)) {
        if (lookup[c.match] != 0xFF) return fail(S::kBadField, kCmdSec, ci);
        lookup[c.match] = static_cast<uint8_t>(k);
      } else {
        for (uint32_t r = 0; r < c.repeat; ++r) {
          for (uint32_t j = 0; j < c.group_len; ++j) {
            const uint32_t reg = c.match + r * c.stride + j;
            if (lookup[reg] != 0xFF) return fail(S::kBadField, kCmdSec, ci);
            lookup[reg] = static_cast<uint8_t>(k);
          }
        }
      }
    }
  }

  // Broadcast commands (PCA9685 ALL_LED_*): both ends are commands of the
  // device, a single group loaded onto every channel of a group as long.
  for (uint32_t dv = 0; dv < device_count_; ++dv) {
    const DeviceRecord& d = devices_[dv];
    if (d.broadcast == 0 && d.broadcast_target == 0) continue;
    if (d.profile != static_cast<uint8_t>(Profile::kRegisterMap) ||
        d.broadcast >= d.command_count || d.broadcast_target >= d.command_count ||
        d.broadcast == d.broadcast_target) {
      return fail(S::kBadReference, kDevSec, dv);
    }
    const CommandRecord& from = commands_[d.command_first + d.broadcast];
    const CommandRecord& to = commands_[d.command_first + d.broadcast_target];
    if (from.repeat != 1 || from.group_len != to.group_len) return fail(S::kBadField, kDevSec, dv);
  }

  // History slots for LAST_FIELD / SINCE_LAST: one per frame command, one per
  // channel of a register group (channels never share a "last value").
  uint32_t slots = 0;
  for (uint32_t i = 0; i < command_count_; ++i) {
    last_first_[i] = static_cast<uint16_t>(slots);
    slots += commands_[i].repeat > 1 ? commands_[i].repeat : 1;
    if (slots > kMaxHistorySlots) return fail(S::kTooMany, kCmdSec, i);
  }

  // --- templates ----------------------------------------------------------------------
  for (uint32_t i = 0; i < template_count_; ++i) {
    const TemplateRecord& t = templates_[i];
    if (t.command != kNone) {
      if (t.command >= command_count_) {
        return fail(S::kBadReference, sec(SectionKind::kTemplates), i);
      }
      const CommandRecord& c = commands_[t.command];
      const uint32_t fc = c.field_count;
      if (devices_[c.device].profile == static_cast<uint8_t>(Profile::kRegisterMap) &&
          c.group_len == 0) {
        return fail(S::kBadReference, sec(SectionKind::kTemplates), i);  // cannot be addressed
      }
      if ((t.set_mask >> fc) != 0) return fail(S::kBadReference, sec(SectionKind::kTemplates), i);
      // A channel must exist; frame commands have none.
      const bool frame = devices_[c.device].profile == static_cast<uint8_t>(Profile::kFrame);
      if (t.index != kSameIndex && (frame || t.index >= c.repeat)) {
        return fail(S::kBadField, sec(SectionKind::kTemplates), i);
      }
    } else if (t.index != kSameIndex) {
      return fail(S::kBadField, sec(SectionKind::kTemplates), i);  // "the checked one" has its own
    }
  }
  // A safe state is written with no command being checked: on a register map
  // each of its templates names its channel.
  for (uint32_t i = 0; i < device_count_; ++i) {
    const DeviceRecord& d = devices_[i];
    if (d.profile != static_cast<uint8_t>(Profile::kRegisterMap)) continue;
    for (uint32_t t = d.safe_first; t < static_cast<uint32_t>(d.safe_first) + d.safe_count; ++t) {
      if (templates_[t].index == kSameIndex) return fail(S::kBadField, kDevSec, i);
    }
  }
  // A rule's template must encode a command of the rule's own device.
  auto template_ok = [&](uint16_t tid, uint16_t device) {
    if (tid == kNone) return true;
    if (tid >= template_count_) return false;
    const uint16_t c = templates_[tid].command;
    return c == kNone || commands_[c].device == device;
  };
  auto mask_ok = [&](const CommandMask& m, uint16_t device) {
    for (uint32_t c = 0; c < 128; ++c) {
      if (internal::mask_has(m, c) && (c >= command_count_ || commands_[c].device != device)) {
        return false;
      }
    }
    return true;
  };
  auto is_actuator = [&](uint16_t device) {
    return device < device_count_ && (devices_[device].role & kRoleActuator) != 0;
  };

  // --- signals (programs checked below) -------------------------------------------------
  const uint32_t kSigSec = sec(SectionKind::kSignals);
  for (uint32_t i = 0; i < signal_count_; ++i) {
    const SignalRecord& s = signals_[i];
    if (s.pad0 != 0) return fail(S::kBadTag, kSigSec, i);
    if (s.kind == static_cast<uint8_t>(SignalKind::kRaw)) {
      if (s.device >= device_count_ || (devices_[s.device].role & kRoleSensor) == 0) {
        return fail(S::kBadReference, kSigSec, i);
      }
      FieldRecord f = s.field;
      if ((f.flags & ~(kFieldBigEndian | kFieldSigned)) != 0 || f.pad[0] || f.pad[1] || f.pad[2]) {
        return fail(S::kBadTag, kSigSec, i);
      }
      if (check_field(f, devices_[s.device].sample_len) != S::kOk || s.valid_min > s.valid_max) {
        return fail(S::kBadField, kSigSec, i);
      }
    } else if (s.kind == static_cast<uint8_t>(SignalKind::kDerived)) {
      if (static_cast<uint32_t>(s.code_first) + s.code_len > code_count_) {
        return fail(S::kBadReference, kSigSec, i);
      }
      derived_mask_ |= uint64_t{1} << i;
    } else {
      return fail(S::kBadTag, kSigSec, i);
    }
  }

  // --- rates ----------------------------------------------------------------------------
  const uint32_t kRateSec = sec(SectionKind::kRates);
  for (uint32_t i = 0; i < rate_count_; ++i) {
    const RateRecord& r = rates_[i];
    if (!response_ok(r.response) || r.reserved != 0) return fail(S::kBadTag, kRateSec, i);
    if (r.task >= task_count_ || !is_actuator(r.device) || !mask_ok(r.commands, r.device) ||
        !template_ok(r.template_id, r.device)) {
      return fail(S::kBadReference, kRateSec, i);
    }
  }

  // --- invariants -----------------------------------------------------------------------
  const uint32_t kInvSec = sec(SectionKind::kInvariants);
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    const InvariantRecord& v = invariants_[i];
    if (!response_ok(v.response) || v.pad != 0) return fail(S::kBadTag, kInvSec, i);
    if (!is_actuator(v.device) || !mask_ok(v.commands, v.device) ||
        !template_ok(v.template_id, v.device) ||
        static_cast<uint32_t>(v.code_first) + v.code_len > code_count_) {
      return fail(S::kBadReference, kInvSec, i);
    }
  }

  // --- access, register init ----------------------------------------------------------------
  const uint32_t device_bits =
      device_count_ >= 32 ? 0xFFFFFFFFu : ((uint32_t{1} << device_count_) - 1);
  for (uint32_t i = 0; i < task_count_; ++i) {
    if ((access_[i].actuate_devices & ~device_bits) != 0 ||
        (access_[i].read_devices & ~device_bits) != 0) {
      return fail(S::kBadReference, sec(SectionKind::kAccess), i);
    }
  }
  for (uint32_t i = 0; i < init.count; ++i) {
    RegisterInitRecord r;
    __builtin_memcpy(&r, image + init.offset + 4u * i, sizeof(r));
    if (r.device >= device_count_ ||
        devices_[r.device].profile != static_cast<uint8_t>(Profile::kRegisterMap)) {
      return fail(S::kBadReference, sec(SectionKind::kRegisterInit), i);
    }
    state_[r.device].shadow[r.reg] = r.value;
  }
  for (uint32_t dv = 0; dv < device_count_; ++dv) {
    __builtin_memcpy(state_[dv].power_on, state_[dv].shadow, kMaxRegisters);
  }

  // --- programs -------------------------------------------------------------------------------
  LoadResult result{S::kOk, 0, 0};
  for (uint32_t i = 0; i < signal_count_; ++i) {
    const SignalRecord& s = signals_[i];
    if (s.kind != static_cast<uint8_t>(SignalKind::kDerived)) continue;
    if (!verify_program(s.code_first, s.code_len, true, static_cast<uint16_t>(i), kNone, &result)) {
      return result;
    }
  }
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    const InvariantRecord& v = invariants_[i];
    if (!verify_program(v.code_first, v.code_len, false, static_cast<uint16_t>(i), v.device,
                        &result)) {
      return result;
    }
  }
  return result;
}

// One program: opcodes and operands, forward jumps inside the program, the
// stack depth along every path (all jumps go forward, so one pass in order
// sees every predecessor of an instruction before the instruction itself).
bool Checker::verify_program(uint32_t code_first, uint32_t code_len, bool derived, uint16_t self,
                             uint16_t device, LoadResult* result) {
  using S = LoadStatus;
  const uint32_t kCodeSec = sec(SectionKind::kCode);
  auto fail_at = [&](S status, uint32_t pc) {
    *result = LoadResult{status, kCodeSec, code_first + pc};
    return false;
  };
  if (code_len > kMaxProgramLength) return fail_at(S::kProgramTooLong, 0);
  if (code_len == 0) return fail_at(S::kNoTerminator, 0);
  int16_t depth_at[kMaxProgramLength];
  for (uint32_t i = 0; i < code_len; ++i) depth_at[i] = -1;
  depth_at[0] = 0;
  uint64_t deps = 0;
  for (uint32_t pc = 0; pc < code_len; ++pc) {
    const Insn& in = code_[code_first + pc];
    if (in.a != 0) return fail_at(S::kBadProgram, pc);
    const int32_t depth = depth_at[pc];
    if (depth < 0) {
      // Unreachable (only jumps lead past a terminator): still must decode.
      if (in.op > static_cast<uint8_t>(Op::kReturn)) return fail_at(S::kBadProgram, pc);
    }
    int32_t pops = 0, pushes = 0;
    bool uses_b = false, uses_imm = false, terminator = false, jump = false, falls = true;
    const Op op = static_cast<Op>(in.op);
    switch (op) {
      case Op::kNop:
        break;
      case Op::kPush:
        pushes = 1;
        uses_imm = true;
        break;
      case Op::kPushConst:
        pushes = 1;
        uses_b = true;
        if (in.b >= constant_count_) return fail_at(S::kBadProgram, pc);
        break;
      case Op::kSignal:
        pushes = 1;
        uses_b = true;
        if (in.b >= signal_count_ || (derived && in.b >= self)) return fail_at(S::kBadProgram, pc);
        if (derived) {
          deps |= signal_deps_[in.b];
          if ((derived_mask_ >> in.b) & 1u) deps |= uint64_t{1} << in.b;
        }
        break;
      case Op::kField:
      case Op::kLastField:
        if (derived) return fail_at(S::kBadProgram, pc);
        pushes = 1;
        uses_b = true;
        if (in.b >= kMaxFieldsPerCommand) return fail_at(S::kBadProgram, pc);
        break;
      case Op::kCommand:
      case Op::kIndex:
      case Op::kJobCount:
      case Op::kSinceLast:
      case Op::kHasLast:
      case Op::kState:
        if (derived) return fail_at(S::kBadProgram, pc);
        pushes = 1;
        break;
      case Op::kSetState:
        if (derived) return fail_at(S::kBadProgram, pc);
        pops = 1;
        break;
      case Op::kAdd:
      case Op::kSub:
      case Op::kMul:
      case Op::kDiv:
      case Op::kMod:
      case Op::kMin:
      case Op::kMax:
      case Op::kEq:
      case Op::kNe:
      case Op::kLt:
      case Op::kLe:
      case Op::kGt:
      case Op::kGe:
      case Op::kAnd:
      case Op::kOr:
        pops = 2;
        pushes = 1;
        break;
      case Op::kNeg:
      case Op::kAbs:
      case Op::kNot:
        pops = 1;
        pushes = 1;
        break;
      case Op::kDup:
        pops = 1;
        pushes = 2;
        break;
      case Op::kDrop:
        pops = 1;
        break;
      case Op::kJumpIfZero:
        pops = 1;
        uses_imm = true;
        jump = true;
        break;
      case Op::kJump:
        uses_imm = true;
        jump = true;
        falls = false;
        break;
      case Op::kSubstBegin:
        if (derived) return fail_at(S::kBadProgram, pc);
        uses_b = true;
        if (in.b != kNone && (in.b >= command_count_ || commands_[in.b].device != device)) {
          return fail_at(S::kBadProgram, pc);
        }
        break;
      case Op::kSubstField:
        if (derived) return fail_at(S::kBadProgram, pc);
        pops = 1;
        uses_b = true;
        if (in.b >= kMaxFieldsPerCommand) return fail_at(S::kBadProgram, pc);
        break;
      case Op::kPass:
      case Op::kFail:
      case Op::kFailSubst:
        if (derived) return fail_at(S::kBadProgram, pc);
        terminator = true;
        falls = false;
        break;
      case Op::kReturn:
        if (!derived) return fail_at(S::kBadProgram, pc);
        pops = 1;
        terminator = true;
        falls = false;
        break;
      default:
        return fail_at(S::kBadProgram, pc);
    }
    if ((!uses_b && in.b != 0) || (!uses_imm && in.imm != 0)) return fail_at(S::kBadProgram, pc);
    if (jump) {
      if (in.imm < 1) return fail_at(S::kJumpBackward, pc);
      if (static_cast<uint64_t>(pc) + static_cast<uint32_t>(in.imm) >= code_len) {
        return fail_at(S::kJumpOutOfRange, pc);
      }
    }
    if (depth < 0) continue;  // unreachable: no stack to track
    if (depth < pops) return fail_at(S::kStackUnderflow, pc);
    const int32_t after = depth - pops + pushes;
    if (after > static_cast<int32_t>(kMaxStackDepth)) return fail_at(S::kStackOverflow, pc);
    if (op == Op::kReturn && depth != 1) return fail_at(S::kStackMismatch, pc);
    (void)terminator;
    auto flow_to = [&](uint32_t target) {
      if (depth_at[target] < 0) {
        depth_at[target] = static_cast<int16_t>(after);
        return true;
      }
      return depth_at[target] == after;
    };
    if (jump && !flow_to(pc + static_cast<uint32_t>(in.imm))) {
      return fail_at(S::kStackMismatch, pc + static_cast<uint32_t>(in.imm));
    }
    if (falls) {
      if (pc + 1 >= code_len) return fail_at(S::kNoTerminator, pc);
      if (!flow_to(pc + 1)) return fail_at(S::kStackMismatch, pc + 1);
    }
  }
  if (derived) signal_deps_[self] = deps;
  return true;
}

// Worst case of one command: the invariants whose mask holds it, plus the
// derived signals those programs can reach (transitively), each counted once.
void Checker::compute_costs() {
  // The sensors each signal can read: a derived program's own SIGNAL operands
  // (all of lower id, so already known) and theirs.
  for (uint32_t s = 0; s < signal_count_; ++s) {
    const SignalRecord& rec = signals_[s];
    if (rec.kind == static_cast<uint8_t>(SignalKind::kRaw)) {
      signal_devices_[s] = uint32_t{1} << rec.device;
      continue;
    }
    uint32_t devs = 0;
    for (uint32_t pc = 0; pc < rec.code_len; ++pc) {
      const Insn& in = code_[rec.code_first + pc];
      if (in.op == static_cast<uint8_t>(Op::kSignal)) devs |= signal_devices_[in.b];
    }
    signal_devices_[s] = devs;
  }
  uint32_t worst = 0;
  uint64_t inv_deps[kMaxInvariants];
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    const InvariantRecord& v = invariants_[i];
    uint64_t deps = 0;
    for (uint32_t pc = 0; pc < v.code_len; ++pc) {
      const Insn& in = code_[v.code_first + pc];
      if (in.op == static_cast<uint8_t>(Op::kSignal)) {
        deps |= signal_deps_[in.b];
        if ((derived_mask_ >> in.b) & 1u) deps |= uint64_t{1} << in.b;
      }
    }
    inv_deps[i] = deps;
  }
  for (uint32_t c = 0; c < command_count_; ++c) {
    uint32_t cost = 0;
    uint64_t deps = 0;
    for (uint32_t i = 0; i < invariant_count_; ++i) {
      if (!internal::mask_has(invariants_[i].commands, c)) continue;
      cost += invariants_[i].code_len;
      deps |= inv_deps[i];
    }
    for (uint32_t s = 0; s < signal_count_; ++s) {
      if ((deps >> s) & 1u) cost += signals_[s].code_len;
    }
    if (cost > worst) worst = cost;
  }
  worst_case_cost_ = worst;
}

}  // namespace contego::core
