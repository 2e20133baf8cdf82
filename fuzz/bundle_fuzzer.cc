// Fuzzes the policy bundle reader (src/bundle/bundle.h), which the trusted
// daemon runs on a file before anything else: any text goes to
// decode_bundle(). Besides crashes (ASan/UBSan) and exceptions (nothing may
// throw on hostile input), an accepted bundle must encode and decode again to
// the same bundle. Seeds: the example policies' bundles (fuzz/corpus/bundle/).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "bundle/bundle.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace contego::bundle;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const contego::Result<Bundle> b = decode_bundle(text, "fuzz");
  if (!b.ok()) return 0;
  const contego::Result<Bundle> again = decode_bundle(encode_bundle(*b), "fuzz");
  if (!again.ok() || again->image != b->image || again->tasks.size() != b->tasks.size() ||
      again->policy != b->policy) {
    std::abort();
  }
  for (size_t i = 0; i < b->tasks.size(); ++i) {
    const BundleTask& x = b->tasks[i];
    const BundleTask& y = again->tasks[i];
    if (x.name != y.name || x.user != y.user || x.group != y.group || x.exe != y.exe ||
        x.unit != y.unit || x.cgroup != y.cgroup || x.sessions != y.sessions ||
        x.phase_us != y.phase_us) {
      std::abort();
    }
  }
  return 0;
}
