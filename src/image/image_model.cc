// Reader of policy images (host side); the writer is serialize.cc, the
// dumper image_dump.cc. The layout is the one docs/image-format.md
// describes: header, section table in kind order, then every payload on a
// 4-byte boundary, NAMES last.
#include "image/image_model.h"

#include <cstring>
#include <fmt/format.h>
#include <map>

#include "contego/core/checker.h"

namespace contego::image {
namespace {

using core::SectionKind;

struct SectionInfo {
  SectionKind kind;
  const char* name;
  uint32_t record_size;
};

// Every section's name and record size, in kind order.
constexpr SectionInfo kSections[] = {
    {SectionKind::kTasks, "TASKS", sizeof(core::TaskRecord)},
    {SectionKind::kDevices, "DEVICES", sizeof(core::DeviceRecord)},
    {SectionKind::kAliases, "ALIASES", sizeof(core::AliasRecord)},
    {SectionKind::kCommands, "COMMANDS", sizeof(core::CommandRecord)},
    {SectionKind::kFields, "FIELDS", sizeof(core::FieldRecord)},
    {SectionKind::kSignals, "SIGNALS", sizeof(core::SignalRecord)},
    {SectionKind::kRates, "RATES", sizeof(core::RateRecord)},
    {SectionKind::kInvariants, "INVARIANTS", sizeof(core::InvariantRecord)},
    {SectionKind::kTemplates, "TEMPLATES", sizeof(core::TemplateRecord)},
    {SectionKind::kCode, "CODE", sizeof(core::Insn)},
    {SectionKind::kConstants, "CONSTANTS", sizeof(int64_t)},
    {SectionKind::kAccess, "ACCESS", sizeof(core::AccessRecord)},
    {SectionKind::kRegisterInit, "REGISTER_INIT", sizeof(core::RegisterInitRecord)},
    {SectionKind::kNames, "NAMES", 1},
};

const SectionInfo* section_info(uint32_t kind) {
  for (const SectionInfo& s : kSections) {
    if (static_cast<uint32_t>(s.kind) == kind) return &s;
  }
  return nullptr;
}

uint32_t record_size(SectionKind kind) {
  const SectionInfo* s = section_info(static_cast<uint32_t>(kind));
  return s != nullptr ? s->record_size : 0;
}

const char* section_name(uint32_t kind) {
  const SectionInfo* s = section_info(kind);
  return s != nullptr ? s->name : "?";
}

}  // namespace

Result<ImageModel> deserialize(std::span<const uint8_t> bytes) {
  core::ImageHeader h{};
  if (bytes.size() < sizeof(h)) {
    return make_error(
        fmt::format("image: {} bytes, shorter than the {}-byte header", bytes.size(), sizeof(h)));
  }
  std::memcpy(&h, bytes.data(), sizeof(h));
  if (h.magic != core::kImageMagic) {
    return make_error(fmt::format("image: bad magic 0x{:08x} at offset 0 (expected 0x{:08x})",
                                  h.magic, core::kImageMagic));
  }
  if (h.version_major != core::kImageVersionMajor) {
    return make_error(fmt::format("image: format version {}.{} (this build reads {}.x)",
                                  h.version_major, h.version_minor, core::kImageVersionMajor));
  }
  if (h.total_size != bytes.size()) {
    return make_error(
        fmt::format("image: header says {} bytes, buffer has {}", h.total_size, bytes.size()));
  }
  const uint64_t table_end = sizeof(h) + uint64_t{h.section_count} * sizeof(core::SectionEntry);
  if (h.section_count > 64 || table_end > bytes.size()) {
    return make_error(
        fmt::format("image: section table of {} entries runs past the end", h.section_count));
  }
  ImageModel m;
  std::vector<uint8_t> names;
  struct Loc {
    uint32_t offset = 0, size = 0, count = 0;
    bool present = false;
  };
  std::map<uint32_t, Loc> sections;
  for (uint32_t i = 0; i < h.section_count; ++i) {
    core::SectionEntry e{};
    std::memcpy(&e, bytes.data() + sizeof(h) + i * sizeof(e), sizeof(e));
    if (uint64_t{e.offset} + e.size > bytes.size()) {
      return make_error(
          fmt::format("image: section {} (kind {}) at offset {} size {} runs past "
                      "the end ({} bytes)",
                      i, e.kind, e.offset, e.size, bytes.size()));
    }
    const uint32_t rs = record_size(static_cast<SectionKind>(e.kind));
    if (rs == 0) {
      return make_error(fmt::format("image: section {} has unknown kind {}", i, e.kind));
    }
    if (uint64_t{e.count} * rs != e.size) {
      return make_error(fmt::format("image: section {} ({}): size {} is not {} records of {} bytes",
                                    i, section_name(e.kind), e.size, e.count, rs));
    }
    sections[e.kind] = Loc{e.offset, e.size, e.count, true};
  }
  auto read = [&]<typename R>(SectionKind kind, std::vector<R>& out) {
    const Loc& l = sections[static_cast<uint32_t>(kind)];
    out.resize(l.count);
    if (l.size != 0) std::memcpy(out.data(), bytes.data() + l.offset, l.size);
  };
  read(SectionKind::kNames, names);
  auto name_at = [&](uint32_t offset, std::string* out) -> bool {
    if (offset >= names.size()) return false;
    const auto* begin = reinterpret_cast<const char*>(names.data() + offset);
    const void* nul = std::memchr(begin, 0, names.size() - offset);
    if (nul == nullptr) return false;
    out->assign(begin, static_cast<const char*>(nul));
    return true;
  };
  std::string error;
  auto read_named = [&]<typename R>(SectionKind kind, std::vector<Named<R>>& out) {
    std::vector<R> records;
    read(kind, records);
    for (size_t i = 0; i < records.size(); ++i) {
      Named<R> n;
      n.record = records[i];
      if (!name_at(records[i].name, &n.name) && error.empty()) {
        error = fmt::format(
            "image: {} record {}: name offset {} is outside NAMES ({} bytes) or "
            "not NUL-terminated",
            section_name(static_cast<uint32_t>(kind)), i, records[i].name, names.size());
      }
      out.push_back(std::move(n));
    }
  };
  read_named(SectionKind::kTasks, m.tasks);
  read_named(SectionKind::kDevices, m.devices);
  read(SectionKind::kAliases, m.aliases);
  read_named(SectionKind::kCommands, m.commands);
  read_named(SectionKind::kFields, m.fields);
  read_named(SectionKind::kSignals, m.signals);
  read_named(SectionKind::kRates, m.rates);
  read_named(SectionKind::kInvariants, m.invariants);
  read(SectionKind::kTemplates, m.templates);
  read(SectionKind::kCode, m.code);
  read(SectionKind::kConstants, m.constants);
  read(SectionKind::kAccess, m.access);
  read(SectionKind::kRegisterInit, m.register_init);
  if (!error.empty()) return make_error(error);
  return m;
}

}  // namespace contego::image
