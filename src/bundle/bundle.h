// A policy bundle: one file with everything that decides what a robot's
// commands may do, so that one hash (or one signature) names all of it:
// the verified image, the task bindings (who may run each task: user,
// group, exe, unit, cgroup, sessions, job phase), where the policy came
// from. The image alone leaves the bindings out (the same SHA-256 with and
// without `user "root"`), so pinning an image did not pin who may act.
//
// `contego check --emit-bundle` writes one; `contego-monitor --bundle`
// loads one and never compiles a policy. The text is JSON (one object, keys
// in a fixed order, the image in hex) so that it can be read, diffed and
// signed as it is (minisign.h).
#ifndef CONTEGO_BUNDLE_BUNDLE_H_
#define CONTEGO_BUNDLE_BUNDLE_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "image/image_model.h"

namespace contego::bundle {

inline constexpr int kBundleVersion = 1;
inline constexpr size_t kMaxBundleBytes = 4u << 20;  // far above any image the core accepts

// Who may run a task (the policy's `task` declaration; peer_identity.h
// resolves it on the host).
struct BundleTask {
  std::string name, exe;
  std::string user, group, unit, cgroup;
  uint32_t sessions = 1;
  std::optional<uint32_t> phase_us;  // declared job phase
  uint8_t ignore_errno = 0;          // what an ignored call fails with; 0: it succeeds
};

struct Bundle {
  std::string policy;  // the policy file it was compiled from (a name for records)
  std::vector<uint8_t> image;
  std::vector<BundleTask> tasks;
  // The host side of what decides, when the bundle names it (`contego check
  // --emit-bundle --budget-factor N --bus N=PATH`): the over-budget hold's
  // factor, and which adapter (/dev/i2c-N) each of the policy's buses is.
  // A daemon's command line may repeat them, never contradict them.
  std::optional<uint32_t> budget_factor;
  std::map<int, std::string> buses;
};

// The bundle's text: stable for equal bundles, ends in a newline.
std::string encode_bundle(const Bundle& bundle);

// The image's SHA-256 in lower-case hex.
std::string image_sha256(const std::vector<uint8_t>& image);

// Reads a bundle written by encode_bundle. Refused, with `source` and the
// field named: not JSON, another format or version, a field of the wrong
// type, an image that is not hex or does not match its `image_sha256`, a
// task binding for a task the image does not declare, or declared twice, a
// bus no device of the image is on or whose adapter is not an absolute path.
// The image is only deserialised here (to match the bindings); the core's
// verifier still decides whether it loads.
Result<Bundle> decode_bundle(std::string_view text, const std::string& source);

}  // namespace contego::bundle

#endif  // CONTEGO_BUNDLE_BUNDLE_H_
