// serialize() and crc32(): the image writer. Kept apart from the reader and
// dumper (image_model.cc) because it needs nothing but the standard library,
// so the core's own tests can build images in a core-only (cross) build.
#include <cstring>
#include <map>

#include "core/internal.h"
#include "image/image_model.h"

namespace contego::image {
namespace {

using core::SectionKind;

constexpr SectionKind kOrder[] = {
    SectionKind::kTasks,        SectionKind::kDevices,    SectionKind::kAliases,
    SectionKind::kCommands,     SectionKind::kFields,     SectionKind::kSignals,
    SectionKind::kRates,        SectionKind::kInvariants, SectionKind::kTemplates,
    SectionKind::kCode,         SectionKind::kConstants,  SectionKind::kAccess,
    SectionKind::kRegisterInit, SectionKind::kNames};

class NameTable {
 public:
  NameTable() { bytes_.push_back(0); }  // offset 0 = ""
  uint32_t add(const std::string& name) {
    if (name.empty()) return 0;
    auto it = offsets_.find(name);
    if (it != offsets_.end()) return it->second;
    const auto offset = static_cast<uint32_t>(bytes_.size());
    bytes_.insert(bytes_.end(), name.begin(), name.end());
    bytes_.push_back(0);
    offsets_.emplace(name, offset);
    return offset;
  }
  const std::vector<uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
  std::map<std::string, uint32_t> offsets_;
};

template <typename R>
std::vector<uint8_t> raw(const std::vector<R>& records) {
  std::vector<uint8_t> out(records.size() * sizeof(R));
  if (!out.empty()) std::memcpy(out.data(), records.data(), out.size());
  return out;
}

template <typename R>
std::vector<uint8_t> named(const std::vector<Named<R>>& records, NameTable& names) {
  std::vector<uint8_t> out(records.size() * sizeof(R));
  for (size_t i = 0; i < records.size(); ++i) {
    R r = records[i].record;
    r.name = names.add(records[i].name);
    std::memcpy(out.data() + i * sizeof(R), &r, sizeof(R));
  }
  return out;
}

}  // namespace

uint32_t crc32(std::span<const uint8_t> bytes) {
  return core::internal::crc32(bytes.data(), bytes.size());
}

std::vector<uint8_t> serialize(const ImageModel& m) {
  NameTable names;
  std::vector<std::vector<uint8_t>> payloads;
  std::vector<uint32_t> counts;
  auto add = [&](std::vector<uint8_t> bytes, size_t count) {
    payloads.push_back(std::move(bytes));
    counts.push_back(static_cast<uint32_t>(count));
  };
  add(named(m.tasks, names), m.tasks.size());
  add(named(m.devices, names), m.devices.size());
  add(raw(m.aliases), m.aliases.size());
  add(named(m.commands, names), m.commands.size());
  add(named(m.fields, names), m.fields.size());
  add(named(m.signals, names), m.signals.size());
  add(named(m.rates, names), m.rates.size());
  add(named(m.invariants, names), m.invariants.size());
  add(raw(m.templates), m.templates.size());
  add(raw(m.code), m.code.size());
  add(raw(m.constants), m.constants.size());
  add(raw(m.access), m.access.size());
  add(raw(m.register_init), m.register_init.size());
  add(names.bytes(), names.bytes().size());

  const uint32_t n = static_cast<uint32_t>(std::size(kOrder));
  uint32_t offset = sizeof(core::ImageHeader) + n * sizeof(core::SectionEntry);
  std::vector<core::SectionEntry> entries;
  for (uint32_t i = 0; i < n; ++i) {
    offset = (offset + 3u) & ~3u;
    entries.push_back(core::SectionEntry{static_cast<uint32_t>(kOrder[i]), offset,
                                         static_cast<uint32_t>(payloads[i].size()), counts[i]});
    offset += static_cast<uint32_t>(payloads[i].size());
  }
  const uint32_t total = (offset + 3u) & ~3u;
  std::vector<uint8_t> out(total, 0);
  core::ImageHeader h{};
  h.magic = core::kImageMagic;
  h.version_major = core::kImageVersionMajor;
  h.version_minor = core::kImageVersionMinor;
  h.total_size = total;
  h.section_count = n;
  std::memcpy(out.data() + sizeof(h), entries.data(), n * sizeof(core::SectionEntry));
  for (uint32_t i = 0; i < n; ++i) {
    if (!payloads[i].empty()) {
      std::memcpy(out.data() + entries[i].offset, payloads[i].data(), payloads[i].size());
    }
  }
  std::memcpy(out.data(), &h, sizeof(h));
  h.checksum = crc32(std::span<const uint8_t>(out).subspan(16));
  std::memcpy(out.data(), &h, sizeof(h));
  return out;
}

}  // namespace contego::image
