// ImageModel: the host-side, editable form of a policy image. The policy
// compiler fills one and serialises it; tools read an image back into one to
// print it. Records are the core's own structs (contego/core/image.h); names
// travel beside them and are written to the NAMES section by serialize().
//
// Host code: allocates freely, never linked into the trusted core.
#ifndef CONTEGO_IMAGE_IMAGE_MODEL_H_
#define CONTEGO_IMAGE_IMAGE_MODEL_H_

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "contego/core/image.h"

#include "base/result.h"

namespace contego::image {

template <typename Record>
struct Named {
  Record record{};
  std::string name;
};

struct ImageModel {
  std::vector<Named<core::TaskRecord>> tasks;
  std::vector<Named<core::DeviceRecord>> devices;
  std::vector<core::AliasRecord> aliases;
  std::vector<Named<core::CommandRecord>> commands;
  std::vector<Named<core::FieldRecord>> fields;
  std::vector<Named<core::SignalRecord>> signals;
  std::vector<Named<core::RateRecord>> rates;
  std::vector<Named<core::InvariantRecord>> invariants;
  std::vector<core::TemplateRecord> templates;
  std::vector<core::Insn> code;
  std::vector<int64_t> constants;
  std::vector<core::AccessRecord> access;  // one per task
  std::vector<core::RegisterInitRecord> register_init;
};

// Lays out header, section table, records and names; computes the checksum.
std::vector<uint8_t> serialize(const ImageModel& model);

// Reads an image back (names resolved). Checks only what it needs to parse
// safely; run core::Checker::load() for the real verification.
Result<ImageModel> deserialize(std::span<const uint8_t> bytes);

// Human-readable listing of every table and a disassembly of every program.
std::string dump(const ImageModel& model);

// CRC-32 (IEEE 802.3, reflected, as zlib's crc32) used by the image checksum.
uint32_t crc32(std::span<const uint8_t> bytes);

}  // namespace contego::image

#endif  // CONTEGO_IMAGE_IMAGE_MODEL_H_
