// Small helpers shared by the core's translation units: little-endian loads,
// field extraction and insertion, bit sets, CRC-32. Freestanding: no library
// calls except what the compiler lowers __builtin_memcpy/memset to.
#ifndef CONTEGO_CORE_INTERNAL_H_
#define CONTEGO_CORE_INTERNAL_H_

#include <stddef.h>
#include <stdint.h>

#include "contego/core/image.h"

namespace contego::core::internal {

// The errno values a refusal answers with (Linux's numbers; no <errno.h>
// in the freestanding core).
inline constexpr uint8_t kEperm = 1;
inline constexpr uint8_t kEnxio = 6;
inline constexpr uint8_t kEinval = 22;

inline uint32_t load_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

// The decisions whose verdict writes to the bus (and settles the model).
inline bool writes(Decision d) { return d == Decision::kAllow || d == Decision::kFailsafe; }
inline bool bit_test(const uint32_t* bits, uint32_t i) { return (bits[i >> 5] >> (i & 31)) & 1u; }
inline void bit_set(uint32_t* bits, uint32_t i) { bits[i >> 5] |= 1u << (i & 31); }
inline void bit_clear(uint32_t* bits, uint32_t i) { bits[i >> 5] &= ~(1u << (i & 31)); }
inline bool mask_has(const CommandMask& m, uint32_t command) {
  return command < 128 && ((m.bits[command >> 5] >> (command & 31)) & 1u) != 0;
}

// The bytes `f` spans, as one integer in the field's byte order.
inline uint64_t field_raw(const FieldRecord& f, const uint8_t* bytes) {
  if (f.nbytes == 1) return bytes[f.offset];  // most fields: no byte order to mind
  uint64_t raw = 0;
  for (uint32_t i = 0; i < f.nbytes; ++i) {
    const uint64_t b = bytes[f.offset + i];
    if (f.flags & kFieldBigEndian) {
      raw = (raw << 8) | b;
    } else {
      raw |= b << (8 * i);
    }
  }
  return raw;
}

// Reads `f` out of `bytes` (caller guarantees offset + nbytes <= length).
inline int32_t field_get(const FieldRecord& f, const uint8_t* bytes) {
  if (f.nbytes == 1) {  // most fields; the verifier keeps shift + width <= 8
    const uint32_t mask = (1u << f.width) - 1;
    uint32_t v = (uint32_t{bytes[f.offset]} >> f.shift) & mask;
    if ((f.flags & kFieldSigned) && ((v >> (f.width - 1)) & 1u)) v |= ~mask;
    return static_cast<int32_t>(v);
  }
  const uint64_t raw = field_raw(f, bytes);
  const uint64_t mask = (f.width >= 32) ? 0xFFFFFFFFull : ((1ull << f.width) - 1);
  uint64_t v = (raw >> f.shift) & mask;
  if ((f.flags & kFieldSigned) && f.width < 64 && ((v >> (f.width - 1)) & 1u)) {
    v |= ~mask;  // sign-extend
  }
  return static_cast<int32_t>(static_cast<uint32_t>(v & 0xFFFFFFFFull));
}

// The range a field can hold.
inline bool field_fits(const FieldRecord& f, int64_t value) {
  if (f.flags & kFieldSigned) {
    const int64_t lo = -(int64_t{1} << (f.width - 1));
    const int64_t hi = (int64_t{1} << (f.width - 1)) - 1;
    return value >= lo && value <= hi;
  }
  const int64_t hi = (int64_t{1} << f.width) - 1;
  return value >= 0 && value <= hi;
}

// Writes `value` into `f` inside `bytes`, keeping the bits outside the field.
// Returns false if the value does not fit.
inline bool field_put(const FieldRecord& f, int64_t value, uint8_t* bytes) {
  if (!field_fits(f, value)) return false;
  uint64_t raw = field_raw(f, bytes);
  const uint64_t mask = ((f.width >= 32) ? 0xFFFFFFFFull : ((1ull << f.width) - 1)) << f.shift;
  raw = (raw & ~mask) | ((static_cast<uint64_t>(value) << f.shift) & mask);
  for (uint32_t i = 0; i < f.nbytes; ++i) {
    const uint32_t shift = (f.flags & kFieldBigEndian) ? 8 * (f.nbytes - 1 - i) : 8 * i;
    bytes[f.offset + i] = static_cast<uint8_t>(raw >> shift);
  }
  return true;
}

// How outcomes combine: the strongest decides a transaction (allow: 0).
inline uint32_t decision_strength(Decision d) {
  switch (d) {
    case Decision::kReject:
      return 3;
    case Decision::kIgnore:
      return 2;
    case Decision::kFailsafe:
      return 1;
    default:
      return 0;
  }
}

// Field arrays are copied whole: one fixed-size copy, where an element loop
// over two int32_t arrays that may alias would be copied one by one.
inline void copy_fields(int32_t (&to)[kMaxFieldsPerCommand],
                        const int32_t (&from)[kMaxFieldsPerCommand]) {
  __builtin_memcpy(to, from, sizeof(to));
}

// CRC-32 (IEEE 802.3, reflected, initial and final xor 0xFFFFFFFF): zlib's crc32().
uint32_t crc32(const uint8_t* data, size_t len);

}  // namespace contego::core::internal

#endif  // CONTEGO_CORE_INTERNAL_H_
