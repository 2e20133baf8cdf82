// The image verifier: CheckerState::load(). Checks everything docs/image-format.md
// promises before a single table is used, in a fixed order, and stops at the
// first problem with (status, section, index). Only then are the tables
// marked loaded: an image is all accepted or all refused.
#include "core/internal.h"
#include "core/state.h"

namespace contego::core::internal {
namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the image is little-endian and the core copies records as they are");

using S = LoadStatus;
using K = SectionKind;

constexpr uint32_t kHeaderSize = sizeof(ImageHeader);
constexpr uint32_t kEntrySize = sizeof(SectionEntry);
constexpr uint32_t kMaxSections = 32;
constexpr uint32_t kNoName = 0xFFFFFFFFu;
constexpr LoadResult kVerified{S::kOk, 0, 0};

LoadResult fail(LoadStatus status, uint32_t section, uint32_t index) {
  return LoadResult{status, section, index};
}

// Ranges of records are (first, count) pairs of 8- or 16-bit fields: their
// sum, `first + count`, is an int and cannot wrap.
constexpr uint32_t sec(SectionKind k) { return static_cast<uint32_t>(k); }
constexpr uint32_t kDevSec = sec(K::kDevices);
constexpr uint32_t kAliasSec = sec(K::kAliases);
constexpr uint32_t kCmdSec = sec(K::kCommands);
constexpr uint32_t kTplSec = sec(K::kTemplates);
constexpr uint32_t kSigSec = sec(K::kSignals);
constexpr uint32_t kRateSec = sec(K::kRates);
constexpr uint32_t kInvSec = sec(K::kInvariants);

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
  if (f.shift + f.width > 8u * f.nbytes) return LoadStatus::kBadField;
  if (f.offset + f.nbytes > limit) return LoadStatus::kBadField;
  return LoadStatus::kOk;
}

bool response_ok(Response r) { return r >= Response::kIgnore && r <= Response::kReject; }

}  // namespace

void CheckerState::clear_tables() {
  __builtin_memset(static_cast<ResetOnLoad*>(this), 0, sizeof(ResetOnLoad));
  journal_.active = false;  // a transfer open across a load is forgotten, not undone
}

LoadResult CheckerState::load(const uint8_t* image, uint32_t size) {
  clear_tables();
  LoadResult r = verify(image, size);
  if (r.status != LoadStatus::kOk) {
    clear_tables();
    return r;
  }
  compute_costs();
  fuse_programs();  // after the costs: they count the image's instructions
  index_rules();
  loaded_ = true;
  return r;
}

// One row per section kind, in kind order: the order of every check below.
struct Section {
  SectionKind kind;
  uint32_t record_size;
  uint32_t max_count;
  void* table = nullptr;       // where the records are copied (null: read in place)
  uint32_t* count = nullptr;   // the number loaded (null: not kept)
  uint32_t name_at = kNoName;  // offset of the records' `name`, kNoName: none
  int entry = -1;              // its index in the image's section table, -1: not seen yet
};

// A section copied into `table`: its record size and capacity are the table's.
template <typename R, uint32_t N>
Section table(SectionKind kind, R (&records)[N], uint32_t* count, uint32_t name_at = kNoName) {
  return Section{kind, sizeof(R), N, records, count, name_at};
}

// The checks of the tables' contents, in order, after the section table.
using Step = LoadResult (CheckerState::*)(const LoadInput&);
constexpr Step kSteps[] = {
    &CheckerState::verify_devices,  &CheckerState::verify_aliases,   &CheckerState::verify_commands,
    &CheckerState::verify_decoding, &CheckerState::verify_templates, &CheckerState::verify_signals,
    &CheckerState::verify_rules,    &CheckerState::verify_access,    &CheckerState::verify_programs,
};

LoadResult CheckerState::verify(const uint8_t* image, uint32_t size) {
  if (image == nullptr || size < kHeaderSize) return fail(S::kTooSmall, 0, 0);
  ImageHeader h;
  __builtin_memcpy(&h, image, sizeof(h));
  if (h.magic != kImageMagic) return fail(S::kBadMagic, 0, 0);
  if (h.version_major != kImageVersionMajor) return fail(S::kBadVersion, 0, 0);
  if (h.total_size != size || size > kMaxImageBytes) return fail(S::kSizeMismatch, 0, 0);
  constexpr uint32_t kSummed = offsetof(ImageHeader, section_count);  // the CRC's first byte
  if (crc32(image + kSummed, size - kSummed) != h.checksum) return fail(S::kBadChecksum, 0, 0);
  if (h.flags != 0 || h.reserved[0] != 0 || h.reserved[1] != 0) return fail(S::kBadHeader, 0, 0);
  if (h.section_count > kMaxSections) return fail(S::kTooMany, 0, 0);
  const uint32_t table_end = kHeaderSize + kEntrySize * h.section_count;
  if (table_end > size) return fail(S::kSectionBounds, 0, 0);

  uint32_t access_count = 0;
  Section sections[] = {
      table(K::kTasks, tasks_, &task_count_, offsetof(TaskRecord, name)),
      table(K::kDevices, devices_, &device_count_, offsetof(DeviceRecord, name)),
      table(K::kAliases, aliases_, &alias_count_),
      table(K::kCommands, commands_, &command_count_, offsetof(CommandRecord, name)),
      table(K::kFields, fields_, &field_count_, offsetof(FieldRecord, name)),
      table(K::kSignals, signals_, &signal_count_, offsetof(SignalRecord, name)),
      table(K::kRates, rates_, &rate_count_, offsetof(RateRecord, name)),
      table(K::kInvariants, invariants_, &invariant_count_, offsetof(InvariantRecord, name)),
      table(K::kTemplates, templates_, &template_count_),
      table(K::kCode, code_, &code_count_),
      table(K::kConstants, constants_, &constant_count_),
      table(K::kAccess, access_, &access_count),
      {K::kRegisterInit, sizeof(RegisterInitRecord), kMaxDevices * kMaxRegisters},
      {K::kNames, 1, kMaxImageBytes},
  };
  constexpr uint32_t kKindCount = sizeof(sections) / sizeof(sections[0]);
  SectionEntry entries[kMaxSections];
  Section* section_of[kMaxSections];

  // The section table. Canonical layout: payloads follow the table in table
  // order, each at the previous end rounded up to 4, zero padding, nothing
  // after the last one. So every byte of the image is accounted for.
  uint32_t cursor = table_end;
  for (uint32_t i = 0; i <= h.section_count; ++i) {
    const bool last = i == h.section_count;
    SectionEntry e{0, size, 0, 0};
    if (!last) __builtin_memcpy(&e, image + kHeaderSize + sizeof(e) * i, sizeof(e));
    Section* sp = nullptr;
    for (Section& x : sections) sp = x.kind == static_cast<K>(e.kind) ? &x : sp;
    if (!last && sp == nullptr) return fail(S::kUnknownSection, e.kind, i);
    if (!last && sp->entry >= 0) return fail(S::kDuplicateSection, e.kind, i);
    const uint64_t end = static_cast<uint64_t>(e.offset) + e.size;
    const uint32_t expected = (cursor + 3u) & ~3u;
    if (e.offset != expected || end > size) return fail(S::kSectionBounds, e.kind, i);
    for (uint32_t p = cursor; p < expected; ++p) {
      if (image[p] != 0) return fail(S::kSectionBounds, e.kind, i);
    }
    if (last) break;
    sp->entry = static_cast<int>(i);
    section_of[i] = sp;
    entries[i] = e;
    cursor = static_cast<uint32_t>(end);
  }
  for (const Section& x : sections) {
    if (x.entry < 0) return fail(S::kMissingSection, sec(x.kind), 0);
  }
  for (uint32_t i = 0; i < h.section_count; ++i) {
    const SectionEntry& e = entries[i];
    if (static_cast<uint64_t>(e.count) * section_of[i]->record_size != e.size) {
      return fail(S::kRecordSize, e.kind, 0);
    }
    if (e.count > section_of[i]->max_count) return fail(S::kTooMany, e.kind, 0);
  }
  // Copy the tables, then check every name.
  for (const Section& x : sections) {
    const SectionEntry& e = entries[x.entry];
    if (x.table != nullptr && e.size != 0) __builtin_memcpy(x.table, image + e.offset, e.size);
    if (x.count != nullptr) *x.count = e.count;
  }
  if (access_count != task_count_) return fail(S::kRecordSize, sec(K::kAccess), 0);
  const SectionEntry& names = entries[sections[kKindCount - 1].entry];
  for (const Section& x : sections) {
    for (uint32_t i = 0; x.name_at != kNoName && i < *x.count; ++i) {
      const uint32_t name =
          load_u32(static_cast<const uint8_t*>(x.table) + x.record_size * i + x.name_at);
      if (!name_ok(image + names.offset, names.size, name)) {
        return fail(S::kBadName, sec(x.kind), i);
      }
    }
  }
  const LoadInput in{image, entries[sections[kKindCount - 2].entry]};
  for (const Step step : kSteps) {
    const LoadResult r = (this->*step)(in);
    if (r.status != S::kOk) return r;
  }
  return kVerified;
}

LoadResult CheckerState::verify_devices(const LoadInput&) {
  for (uint32_t i = 0; i < device_count_; ++i) {
    const DeviceRecord& d = devices_[i];
    if (d.role == 0 || (d.role & ~(kRoleActuator | kRoleSensor)) != 0 ||
        (d.profile != Profile::kFrame && d.profile != Profile::kRegisterMap) || d.ten_bit > 1 ||
        d.auto_increment > AutoIncrement::kBit || d.latch_mode > LatchMode::kHoldSafeUnrepaired ||
        d.short_queries > 1 || d.gate_bit > 7 ||
        (d.gated != 0 && (d.profile != Profile::kRegisterMap || d.gated > d.command_count)) ||
        (d.short_queries != 0 && d.profile != Profile::kFrame)) {
      return fail(S::kBadTag, kDevSec, i);
    }
    if (d.addr > (d.ten_bit ? 0x3FFu : 0x7Fu) || d.ai_bit > 7 ||
        d.sample_request_len > sizeof(d.sample_request) || d.sample_len > kMaxSampleBytes ||
        (d.profile == Profile::kFrame &&
         (d.frame_len < 1 || d.prefix_len > 1 || d.frame_len + d.prefix_len > kMaxWriteBytes)) ||
        (d.latch_mode != LatchMode::kOff &&
         (d.latch_count < 1 || d.latch_count > kMaxLatchCount))) {
      return fail(S::kBadField, kDevSec, i);
    }
    if (d.command_first + d.command_count > command_count_) {
      return fail(S::kBadReference, kDevSec, i);
    }
    for (uint32_t c = d.command_first; c < d.command_first + d.command_count; ++c) {
      if (commands_[c].device != i) return fail(S::kBadReference, kDevSec, i);
    }
    if (d.safe_count > kMaxSafeStateCommands) return fail(S::kTooMany, kDevSec, i);
    if (d.safe_first + d.safe_count > template_count_) return fail(S::kBadReference, kDevSec, i);
    for (uint32_t t = d.safe_first; t < d.safe_first + d.safe_count; ++t) {
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
  return kVerified;
}

LoadResult CheckerState::verify_aliases(const LoadInput&) {
  for (uint32_t i = 0; i < alias_count_; ++i) {
    const AliasRecord& a = aliases_[i];
    if (a.kind > AliasKind::kGeneralCall || a.pad != 0) return fail(S::kBadTag, kAliasSec, i);
    if (a.device >= device_count_) return fail(S::kBadReference, kAliasSec, i);
    if (a.addr > 0x7F || (a.kind == AliasKind::kGeneralCall && a.addr != 0) ||
        (a.kind == AliasKind::kAddress && a.addr == 0)) {
      return fail(S::kBadField, kAliasSec, i);
    }
  }
  return kVerified;
}

LoadResult CheckerState::verify_commands(const LoadInput&) {
  for (uint32_t i = 0; i < command_count_; ++i) {
    const CommandRecord& c = commands_[i];
    if (c.device >= device_count_) return fail(S::kBadReference, kCmdSec, i);
    const DeviceRecord& d = devices_[c.device];
    if (i < d.command_first || i >= d.command_first + d.command_count) {
      return fail(S::kBadReference, kCmdSec, i);  // not inside its device's range
    }
    if (c.command_class < CommandClass::kActuate || c.command_class > CommandClass::kForbidden) {
      return fail(S::kBadTag, kCmdSec, i);
    }
    if (c.field_count > kMaxFieldsPerCommand) return fail(S::kTooMany, kCmdSec, i);
    if (c.field_first + c.field_count > field_count_) return fail(S::kBadReference, kCmdSec, i);
    uint32_t limit = 0;
    if (d.profile == Profile::kFrame) {
      if (c.group_len != 0 || c.repeat != 0 || c.stride != 0) return fail(S::kBadField, kCmdSec, i);
      limit = d.frame_len;
    } else if (c.group_len == 0) {
      // A general-call command: one byte, no fields, on a general-call listener.
      if (c.repeat != 0 || c.stride != 0 || c.field_count != 0) {
        return fail(S::kBadField, kCmdSec, i);
      }
      bool listens = false;
      for (uint32_t a = 0; a < alias_count_; ++a) {
        listens = listens ||
                  (aliases_[a].device == c.device && aliases_[a].kind == AliasKind::kGeneralCall);
      }
      if (!listens) return fail(S::kBadReference, kCmdSec, i);
      for (uint32_t k = d.command_first; k < i; ++k) {
        if (commands_[k].group_len == 0 && commands_[k].match == c.match) {
          return fail(S::kBadField, kCmdSec, i);  // two general-call commands, one byte
        }
      }
    } else {
      if (c.group_len < 1 || c.repeat < 1 || (c.repeat > 1 && c.stride < c.group_len) ||
          c.match + static_cast<uint32_t>(c.repeat - 1) * c.stride + c.group_len > kMaxRegisters) {
        return fail(S::kBadField, kCmdSec, i);  // overlapping channels, or past the last register
      }
      limit = c.group_len;
    }
    for (uint32_t f = c.field_first; f < c.field_first + c.field_count; ++f) {
      const LoadStatus st = check_field(fields_[f], limit);
      if (st != S::kOk) return fail(st, sec(K::kFields), f);
    }
  }
  return kVerified;
}

LoadResult CheckerState::verify_decoding(const LoadInput&) {
  // Per-device lookup tables: opcode (frame) or register (map) -> command. Two
  // commands claiming one opcode or register make decoding ambiguous.
  for (uint32_t dv = 0; dv < device_count_; ++dv) {
    uint8_t* lookup = state_[dv].lookup;
    __builtin_memset(lookup, 0xFF, kMaxRegisters);
    const DeviceRecord& d = devices_[dv];
    for (uint32_t k = 0; k < d.command_count; ++k) {
      const uint32_t ci = d.command_first + k;
      const CommandRecord& c = commands_[ci];
      if (d.profile == Profile::kFrame) {
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
    if (d.profile != Profile::kRegisterMap || d.broadcast >= d.command_count ||
        d.broadcast_target >= d.command_count || d.broadcast == d.broadcast_target) {
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
  return kVerified;
}

LoadResult CheckerState::verify_templates(const LoadInput&) {
  for (uint32_t i = 0; i < template_count_; ++i) {
    const TemplateRecord& t = templates_[i];
    if (t.command != kNone) {
      const CommandRecord& c = commands_[t.command < command_count_ ? t.command : 0];
      // A command of the image, addressable (not a general call), with the fields it sets.
      if (t.command >= command_count_ ||
          (devices_[c.device].profile == Profile::kRegisterMap && c.group_len == 0) ||
          (t.set_mask >> c.field_count) != 0) {
        return fail(S::kBadReference, kTplSec, i);
      }
      // A channel must exist; frame commands have none.
      const bool frame = devices_[c.device].profile == Profile::kFrame;
      if (t.index != kSameIndex && (frame || t.index >= c.repeat)) {
        return fail(S::kBadField, kTplSec, i);
      }
    } else if (t.index != kSameIndex) {
      return fail(S::kBadField, kTplSec, i);  // "the checked one" has its own
    }
  }
  // A safe state is written with no command being checked: on a register map
  // each of its templates names its channel.
  for (uint32_t i = 0; i < device_count_; ++i) {
    const DeviceRecord& d = devices_[i];
    if (d.profile != Profile::kRegisterMap) continue;
    for (uint32_t t = d.safe_first; t < d.safe_first + d.safe_count; ++t) {
      if (templates_[t].index == kSameIndex) return fail(S::kBadField, kDevSec, i);
    }
  }
  return kVerified;
}

LoadResult CheckerState::verify_signals(const LoadInput&) {
  for (uint32_t i = 0; i < signal_count_; ++i) {
    const SignalRecord& s = signals_[i];
    if (s.pad0 != 0) return fail(S::kBadTag, kSigSec, i);
    if (s.kind == SignalKind::kRaw) {
      if (s.device >= device_count_ || (devices_[s.device].role & kRoleSensor) == 0) {
        return fail(S::kBadReference, kSigSec, i);
      }
      const LoadStatus st = check_field(s.field, devices_[s.device].sample_len);
      if (st != S::kOk) return fail(st, kSigSec, i);
      if (s.valid_min > s.valid_max) return fail(S::kBadField, kSigSec, i);
      signal_devices_[i] = uint32_t{1} << s.device;
    } else if (s.kind == SignalKind::kDerived) {
      if (s.code_first + s.code_len > code_count_) return fail(S::kBadReference, kSigSec, i);
      derived_mask_ |= uint64_t{1} << i;
    } else {
      return fail(S::kBadTag, kSigSec, i);
    }
  }
  return kVerified;
}

LoadResult CheckerState::verify_rules(const LoadInput&) {
  // A rule's template must encode a command of the rule's own device.
  auto template_ok = [&](uint16_t tid, uint16_t device) {
    if (tid == kNone) return true;
    if (tid >= template_count_) return false;
    const uint16_t c = templates_[tid].command;
    return c == kNone || commands_[c].device == device;
  };
  auto mask_ok = [&](const CommandMask& m, uint16_t device) {
    for (uint32_t c = 0; c < 128; ++c) {
      if (mask_has(m, c) && (c >= command_count_ || commands_[c].device != device)) return false;
    }
    return true;
  };
  auto is_actuator = [&](uint16_t device) {
    return device < device_count_ && (devices_[device].role & kRoleActuator) != 0;
  };

  for (uint32_t i = 0; i < rate_count_; ++i) {
    const RateRecord& r = rates_[i];
    if (!response_ok(r.response) || r.reserved != 0) return fail(S::kBadTag, kRateSec, i);
    if (r.task >= task_count_ || !is_actuator(r.device) || !mask_ok(r.commands, r.device) ||
        !template_ok(r.template_id, r.device)) {
      return fail(S::kBadReference, kRateSec, i);
    }
  }

  for (uint32_t i = 0; i < invariant_count_; ++i) {
    const InvariantRecord& v = invariants_[i];
    if (!response_ok(v.response) || v.scope > StateScope::kSession ||
        (v.after_safe != 0 && v.scope != StateScope::kDevice)) {
      return fail(S::kBadTag, kInvSec, i);
    }
    if (!is_actuator(v.device) || !mask_ok(v.commands, v.device) ||
        !template_ok(v.template_id, v.device) || v.code_first + v.code_len > code_count_) {
      return fail(S::kBadReference, kInvSec, i);
    }
  }
  return kVerified;
}

LoadResult CheckerState::verify_access(const LoadInput& in) {
  const uint32_t device_bits =
      device_count_ >= 32 ? 0xFFFFFFFFu : ((uint32_t{1} << device_count_) - 1);
  for (uint32_t i = 0; i < task_count_; ++i) {
    if ((access_[i].actuate_devices & ~device_bits) != 0 ||
        (access_[i].read_devices & ~device_bits) != 0) {
      return fail(S::kBadReference, sec(K::kAccess), i);
    }
  }
  for (uint32_t i = 0; i < in.init.count; ++i) {
    RegisterInitRecord r;
    __builtin_memcpy(&r, in.image + in.init.offset + sizeof(r) * i, sizeof(r));
    if (r.device >= device_count_ || devices_[r.device].profile != Profile::kRegisterMap) {
      return fail(S::kBadReference, sec(K::kRegisterInit), i);
    }
    state_[r.device].shadow[r.reg] = r.value;
  }
  for (uint32_t dv = 0; dv < device_count_; ++dv) {
    __builtin_memcpy(state_[dv].power_on, state_[dv].shadow, kMaxRegisters);
  }
  return kVerified;
}

LoadResult CheckerState::verify_programs(const LoadInput&) {
  LoadResult result = kVerified;
  for (uint32_t i = 0; i < signal_count_; ++i) {
    const SignalRecord& s = signals_[i];
    if (s.kind != SignalKind::kDerived) continue;
    if (!verify_program(s.code_first, s.code_len, true, static_cast<uint16_t>(i), kNone, &result)) {
      return result;
    }
    const Reach r = reach(s.code_first, s.code_len);
    signal_deps_[i] = r.signals;
    signal_devices_[i] = r.sensors;
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

namespace {

// What the verifier knows of each opcode: stack effect, operands, flow.
enum OpFlags : uint8_t {
  kValid = 1,
  kUsesB = 2,
  kUsesImm = 4,
  kJumps = 8,
  kEnds = 16,           // no fall-through to the next instruction
  kInvariantOnly = 32,  // reads the checked command or its history, or decides
  kDerivedOnly = 64,
};
struct OpInfo {
  uint8_t pops;
  uint8_t pushes;
  uint8_t flags;
};
struct OpTable {
  OpInfo at[static_cast<uint32_t>(Op::kReturn) + 1];
};
constexpr OpTable make_op_table() {
  OpTable t{};
  auto set = [&t](Op op, uint8_t pops, uint8_t pushes, uint32_t flags) {
    t.at[static_cast<uint8_t>(op)] = OpInfo{pops, pushes, static_cast<uint8_t>(flags | kValid)};
  };
  constexpr Op kContext[] = {Op::kCommand,   Op::kIndex,   Op::kJobCount,
                             Op::kSinceLast, Op::kHasLast, Op::kState};
  constexpr Op kBinary[] = {Op::kAdd, Op::kSub, Op::kMul, Op::kDiv, Op::kMod,
                            Op::kMin, Op::kMax, Op::kEq,  Op::kNe,  Op::kLt,
                            Op::kLe,  Op::kGt,  Op::kGe,  Op::kAnd, Op::kOr};
  for (const Op op : kContext) set(op, 0, 1, kInvariantOnly);
  for (const Op op : kBinary) set(op, 2, 1, 0);
  set(Op::kNop, 0, 0, 0);
  set(Op::kPush, 0, 1, kUsesImm);
  set(Op::kPushConst, 0, 1, kUsesB);
  set(Op::kSignal, 0, 1, kUsesB);
  set(Op::kField, 0, 1, kUsesB | kInvariantOnly);
  set(Op::kLastField, 0, 1, kUsesB | kInvariantOnly);
  set(Op::kSetState, 1, 0, kInvariantOnly);
  set(Op::kNeg, 1, 1, 0);
  set(Op::kAbs, 1, 1, 0);
  set(Op::kNot, 1, 1, 0);
  set(Op::kDup, 1, 2, 0);
  set(Op::kDrop, 1, 0, 0);
  set(Op::kJumpIfZero, 1, 0, kUsesImm | kJumps);
  set(Op::kJump, 0, 0, kUsesImm | kJumps | kEnds);
  set(Op::kSubstBegin, 0, 0, kUsesB | kInvariantOnly);
  set(Op::kSubstField, 1, 0, kUsesB | kInvariantOnly);
  set(Op::kPass, 0, 0, kEnds | kInvariantOnly);
  set(Op::kFail, 0, 0, kEnds | kInvariantOnly);
  set(Op::kFailSubst, 0, 0, kEnds | kInvariantOnly);
  set(Op::kReturn, 1, 0, kEnds | kDerivedOnly);
  return t;
}
constexpr OpTable kOps = make_op_table();

}  // namespace

// The operand b of one instruction names something that exists.
bool CheckerState::operand_ok(const Insn& in, bool derived, uint16_t self, uint16_t device) const {
  switch (in.op) {
    case Op::kPushConst:
      return in.b < constant_count_;
    case Op::kSignal:
      return in.b < signal_count_ && !(derived && in.b >= self);
    case Op::kField:
    case Op::kLastField:
    case Op::kSubstField:
      return in.b < kMaxFieldsPerCommand;
    case Op::kSubstBegin:
      return in.b == kNone || (in.b < command_count_ && commands_[in.b].device == device);
    default:
      return true;
  }
}

// One program: opcodes and operands, forward jumps inside the program, the
// stack depth along every path (all jumps go forward, so one pass in order
// sees every predecessor of an instruction before the instruction itself).
bool CheckerState::verify_program(uint32_t code_first, uint32_t code_len, bool derived,
                                  uint16_t self, uint16_t device, LoadResult* result) {
  auto fail_at = [&](S status, uint32_t pc) {
    *result = LoadResult{status, sec(K::kCode), code_first + pc};
    return false;
  };
  if (code_len > kMaxProgramLength) return fail_at(S::kProgramTooLong, 0);
  if (code_len == 0) return fail_at(S::kNoTerminator, 0);
  int16_t depth_at[kMaxProgramLength];
  for (uint32_t i = 0; i < code_len; ++i) depth_at[i] = -1;
  depth_at[0] = 0;
  for (uint32_t pc = 0; pc < code_len; ++pc) {
    const Insn& in = code_[code_first + pc];
    const OpInfo op = in.op <= Op::kReturn ? kOps.at[static_cast<uint8_t>(in.op)] : OpInfo{};
    const uint32_t wrong_kind = derived ? kInvariantOnly : kDerivedOnly;
    if (in.a != 0 || (op.flags & kValid) == 0 || (op.flags & wrong_kind) != 0 ||
        ((op.flags & kUsesB) == 0 && in.b != 0) || ((op.flags & kUsesImm) == 0 && in.imm != 0) ||
        !operand_ok(in, derived, self, device)) {
      return fail_at(S::kBadProgram, pc);
    }
    const uint32_t target = pc + static_cast<uint32_t>(in.imm);
    if ((op.flags & kJumps) != 0) {
      if (in.imm < 1) return fail_at(S::kJumpBackward, pc);
      if (static_cast<uint64_t>(pc) + static_cast<uint32_t>(in.imm) >= code_len) {
        return fail_at(S::kJumpOutOfRange, pc);
      }
    }
    const int32_t depth = depth_at[pc];
    if (depth < 0) continue;  // unreachable (only jumps lead past an end): no stack to track
    if (depth < op.pops) return fail_at(S::kStackUnderflow, pc);
    const int32_t after = depth - op.pops + op.pushes;
    if (after > static_cast<int32_t>(kMaxStackDepth)) return fail_at(S::kStackOverflow, pc);
    if (in.op == Op::kReturn && depth != 1) return fail_at(S::kStackMismatch, pc);
    auto flow_to = [&](uint32_t to) {
      if (depth_at[to] < 0) depth_at[to] = static_cast<int16_t>(after);
      return depth_at[to] == after;
    };
    if ((op.flags & kJumps) != 0 && !flow_to(target)) return fail_at(S::kStackMismatch, target);
    if ((op.flags & kEnds) == 0) {
      if (pc + 1 >= code_len) return fail_at(S::kNoTerminator, pc);
      if (!flow_to(pc + 1)) return fail_at(S::kStackMismatch, pc + 1);
    }
  }
  return true;
}

// What a verified program's SIGNAL operands reach: the derived signals (and
// those they need, transitively) and the sensors. Its signals are of lower
// id than any derived signal it computes, so theirs are already known.
Reach CheckerState::reach(uint32_t code_first, uint32_t code_len) const {
  Reach r{0, 0};
  for (uint32_t pc = 0; pc < code_len; ++pc) {
    const Insn& in = code_[code_first + pc];
    if (in.op != Op::kSignal) continue;
    r.signals |= signal_deps_[in.b] | (derived_mask_ & (uint64_t{1} << in.b));
    r.sensors |= signal_devices_[in.b];
  }
  return r;
}

// Worst case of one command: the invariants whose mask holds it, plus the
// derived signals those programs can reach (transitively), each counted once.
void CheckerState::compute_costs() {
  uint32_t worst = 0;
  uint64_t inv_deps[kMaxInvariants];
  for (uint32_t i = 0; i < invariant_count_; ++i) {
    inv_deps[i] = reach(invariants_[i].code_first, invariants_[i].code_len).signals;
  }
  for (uint32_t c = 0; c < command_count_; ++c) {
    uint32_t cost = 0;
    uint64_t deps = 0;
    for (uint32_t i = 0; i < invariant_count_; ++i) {
      if (!mask_has(invariants_[i].commands, c)) continue;
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

}  // namespace contego::core::internal
