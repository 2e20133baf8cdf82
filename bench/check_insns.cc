// The trusted core's cost of one check in machine instructions, counted by
// callgrind (bench/check_insns.sh): loads a verified image (`contego check
// --emit`) through the C facade -- the entry point contego.ko uses -- and
// checks one write N times, as the kernel does for each call. Counting
// instructions rather than time makes the figure repeatable on a shared,
// noisy machine and comparable with the guest bench's TCG figures, which
// mean little in microseconds.
//
// Usage: check_insns IMAGE TASK BUS ADDR HEXBYTES N
//   e.g. check_insns arm.img 0 1 0x40 fd00 10000
// HEXBYTES may name several writes, comma-separated (fd00,fd10), checked in
// turn: a model that changes on every check. Prints how many checks allowed
// and the last decision.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "contego/core_c.h"

int main(int argc, char** argv) {
  if (argc != 7) {
    std::fprintf(stderr, "usage: check_insns IMAGE TASK BUS ADDR HEXBYTES N\n");
    return 2;
  }
  std::ifstream in(argv[1], std::ios::binary);
  const std::vector<uint8_t> image((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  const std::string hex = argv[5];
  std::vector<std::vector<uint8_t>> writes(1);
  for (size_t i = 0; i < hex.size();) {
    if (hex[i] == ',') {
      writes.emplace_back();
      ++i;
      continue;
    }
    writes.back().push_back(static_cast<uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
    i += 2;
  }
  bool empty = false;
  for (const auto& w : writes) empty = empty || w.empty();
  const long n = std::strtol(argv[6], nullptr, 10);
  if (image.empty() || empty || n <= 0) {
    std::fprintf(stderr, "check_insns: no image, no bytes or no count\n");
    return 2;
  }
  const size_t size = contego_checker_size() + contego_checker_align();
  auto mem = std::make_unique<unsigned char[]>(size);
  void* aligned = mem.get();
  size_t space = size;
  aligned = std::align(contego_checker_align(), contego_checker_size(), aligned, space);
  contego_checker* c = contego_checker_init(aligned, contego_checker_size());
  const contego_load_result r = contego_load(c, image.data(), static_cast<uint32_t>(image.size()));
  if (c == nullptr || r.status != 0) {
    std::fprintf(stderr, "check_insns: image refused: %s\n", contego_load_status_name(r.status));
    return 2;
  }
  contego_transaction tx{};
  tx.task = static_cast<uint16_t>(std::strtoul(argv[2], nullptr, 0));
  tx.bus = static_cast<uint8_t>(std::strtoul(argv[3], nullptr, 0));
  tx.kind = CONTEGO_TX_WRITE;
  tx.addr = static_cast<uint16_t>(std::strtoul(argv[4], nullptr, 0));
  tx.job = 1;
  contego_verdict v{};
  long allowed = 0;
  for (long i = 0; i < n; ++i) {
    const std::vector<uint8_t>& bytes = writes[static_cast<size_t>(i) % writes.size()];
    tx.len = static_cast<uint32_t>(bytes.size());
    tx.bytes = bytes.data();
    tx.now_us = 1000 + static_cast<uint64_t>(i);
    contego_check(c, &tx, &v);
    allowed += v.decision == CONTEGO_ALLOW;
  }
  std::printf("checks=%ld allowed=%ld last=%s (%s)\n", n, allowed,
              contego_decision_name(v.decision), contego_reason_name(v.reason));
  return 0;
}
