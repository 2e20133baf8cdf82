#include "bundle/bundle.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <openssl/evp.h>
#include <set>

namespace contego::bundle {
namespace {

constexpr const char* kFormat = "contego-policy-bundle";

std::string hex(const uint8_t* data, size_t n) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out(n * 2, '0');
  for (size_t i = 0; i < n; ++i) {
    out[2 * i] = kDigits[data[i] >> 4];
    out[2 * i + 1] = kDigits[data[i] & 15];
  }
  return out;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;  // upper case is not what encode_bundle writes: refused, one form only
}

// Fields are read with explicit type checks: nlohmann's get<> throws on a
// wrong type, and nothing here may throw on hostile input.
class Reader {
 public:
  Reader(const nlohmann::json& object, std::string where) : o_(object), where_(std::move(where)) {}
  Result<std::string> string(const char* key, bool required = true) const {
    auto it = o_.find(key);
    if (it == o_.end()) {
      if (!required) return std::string();
      return make_error(fmt::format("{}: missing \"{}\"", where_, key));
    }
    if (!it->is_string())
      return make_error(fmt::format("{}: \"{}\" must be a string", where_, key));
    return it->get_ref<const std::string&>();
  }
  Result<std::optional<uint32_t>> count(const char* key, uint32_t max = UINT32_MAX) const {
    auto it = o_.find(key);
    if (it == o_.end() || it->is_null()) return std::optional<uint32_t>();
    if (!it->is_number_unsigned() || it->get<uint64_t>() > max) {
      return make_error(
          fmt::format("{}: \"{}\" must be an integer from 0 to {}", where_, key, max));
    }
    return std::optional<uint32_t>(static_cast<uint32_t>(it->get<uint64_t>()));
  }

 private:
  const nlohmann::json& o_;
  std::string where_;
};

}  // namespace

std::string image_sha256(const std::vector<uint8_t>& image) {
  uint8_t digest[32];
  unsigned int n = 0;
  if (EVP_Digest(image.data(), image.size(), digest, &n, EVP_sha256(), nullptr) != 1 || n != 32) {
    return std::string(64, '0');  // libcrypto without SHA-256: never matches a real hash
  }
  return hex(digest, sizeof(digest));
}

std::string encode_bundle(const Bundle& b) {
  // nlohmann's ordered_json keeps the insertion order: one text per bundle.
  nlohmann::ordered_json doc;
  doc["format"] = kFormat;
  doc["version"] = kBundleVersion;
  doc["policy"] = b.policy;
  doc["image_sha256"] = image_sha256(b.image);
  nlohmann::ordered_json tasks = nlohmann::ordered_json::array();
  for (const BundleTask& t : b.tasks) {
    nlohmann::ordered_json j;
    j["name"] = t.name;
    for (auto [key, value] :
         {std::pair{"user", &t.user}, std::pair{"group", &t.group}, std::pair{"exe", &t.exe},
          std::pair{"unit", &t.unit}, std::pair{"cgroup", &t.cgroup}}) {
      if (!value->empty()) j[key] = *value;
    }
    j["sessions"] = t.sessions;
    if (t.phase_us) j["phase_us"] = *t.phase_us;
    if (t.ignore_errno != 0) j["ignore_errno"] = t.ignore_errno;
    tasks.push_back(std::move(j));
  }
  doc["tasks"] = std::move(tasks);
  // Only when named: a bundle without them keeps its text (and signature).
  if (b.budget_factor) doc["budget_factor"] = *b.budget_factor;
  if (!b.buses.empty()) {
    nlohmann::ordered_json buses = nlohmann::ordered_json::object();
    for (const auto& [n, path] : b.buses) buses[std::to_string(n)] = path;
    doc["buses"] = std::move(buses);
  }
  doc["image"] = hex(b.image.data(), b.image.size());
  return doc.dump(1) + "\n";
}

Result<Bundle> decode_bundle(std::string_view text, const std::string& source) {
  if (text.size() > kMaxBundleBytes) {
    return make_error(fmt::format("bundle {}: {} bytes, more than a bundle may have ({})", source,
                                  text.size(), kMaxBundleBytes));
  }
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) {
    return make_error(
        fmt::format("bundle {}: not a JSON object (a policy bundle is written by "
                    "`contego check --emit-bundle`)",
                    source));
  }
  const std::string where = "bundle " + source;
  Reader top(doc, where);
  auto format = top.string("format");
  if (!format) return make_error(format.error());
  if (*format != kFormat) {
    return make_error(fmt::format("{}: format \"{}\" is not \"{}\"", where, *format, kFormat));
  }
  auto version = top.count("version");
  if (!version) return make_error(version.error());
  if (*version != std::optional<uint32_t>(kBundleVersion)) {
    return make_error(fmt::format("{}: version {} is not the version this contego reads ({})",
                                  where, version->value_or(0), kBundleVersion));
  }
  Bundle b;
  auto policy = top.string("policy");
  if (!policy) return make_error(policy.error());
  b.policy = *policy;
  auto image_hex = top.string("image");
  if (!image_hex) return make_error(image_hex.error());
  if (image_hex->size() % 2 != 0) {
    return make_error(fmt::format("{}: \"image\" has an odd number of hex digits", where));
  }
  b.image.resize(image_hex->size() / 2);
  for (size_t i = 0; i < b.image.size(); ++i) {
    const int hi = hex_digit((*image_hex)[2 * i]);
    const int lo = hex_digit((*image_hex)[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      return make_error(
          fmt::format("{}: \"image\" is not lower-case hex (at digit {})", where, 2 * i));
    }
    b.image[i] = static_cast<uint8_t>(hi << 4 | lo);
  }
  auto declared = top.string("image_sha256");
  if (!declared) return make_error(declared.error());
  if (const std::string actual = image_sha256(b.image); actual != *declared) {
    return make_error(
        fmt::format("{}: the image's SHA-256 is {}, not the image_sha256 it declares "
                    "({}): the file was changed",
                    where, actual, *declared));
  }
  auto model = image::deserialize(b.image);
  if (!model) return make_error(fmt::format("{}: {}", where, model.error()));
  std::set<std::string> image_tasks;
  for (const auto& t : model->tasks) image_tasks.insert(t.name);

  auto tasks = doc.find("tasks");
  if (tasks == doc.end() || !tasks->is_array()) {
    return make_error(fmt::format("{}: \"tasks\" must be an array", where));
  }
  std::set<std::string> seen;
  for (size_t i = 0; i < tasks->size(); ++i) {
    const nlohmann::json& j = (*tasks)[i];
    const std::string at = fmt::format("{}: tasks[{}]", where, i);
    if (!j.is_object()) return make_error(at + ": not an object");
    Reader r(j, at);
    BundleTask t;
    auto name = r.string("name");
    if (!name) return make_error(name.error());
    t.name = *name;
    if (!image_tasks.contains(t.name)) {
      return make_error(fmt::format("{}: the image declares no task '{}'", at, t.name));
    }
    if (!seen.insert(t.name).second) {
      return make_error(fmt::format("{}: task '{}' is bound twice", at, t.name));
    }
    for (auto [key, out] :
         {std::pair{"user", &t.user}, std::pair{"group", &t.group}, std::pair{"exe", &t.exe},
          std::pair{"unit", &t.unit}, std::pair{"cgroup", &t.cgroup}}) {
      auto v = r.string(key, /*required=*/false);
      if (!v) return make_error(v.error());
      *out = *v;
    }
    auto sessions = r.count("sessions");
    if (!sessions) return make_error(sessions.error());
    t.sessions = sessions->value_or(1);
    if (t.sessions == 0) return make_error(at + ": \"sessions\" must be at least 1");
    auto phase = r.count("phase_us");
    if (!phase) return make_error(phase.error());
    t.phase_us = *phase;
    auto ignore_errno = r.count("ignore_errno", 255);
    if (!ignore_errno) return make_error(ignore_errno.error());
    t.ignore_errno = static_cast<uint8_t>(ignore_errno->value_or(0));
    b.tasks.push_back(std::move(t));
  }
  auto factor = top.count("budget_factor");
  if (!factor) return make_error(factor.error());
  b.budget_factor = *factor;
  if (auto buses = doc.find("buses"); buses != doc.end()) {
    if (!buses->is_object()) {
      return make_error(
          fmt::format("{}: \"buses\" must be an object (bus number: adapter)", where));
    }
    std::set<int> used;
    for (const auto& d : model->devices) used.insert(d.record.bus);
    for (const auto& [key, value] : buses->items()) {
      const std::string at = fmt::format("{}: buses[\"{}\"]", where, key);
      if (key.empty() || key.size() > 3 ||
          key.find_first_not_of("0123456789") != std::string::npos || std::stoi(key) > 255) {
        return make_error(at + ": the key must be a bus number from 0 to 255");
      }
      const int n = std::stoi(key);
      if (!used.contains(n))
        return make_error(fmt::format("{}: no device of the image is on bus {}", at, n));
      if (!value.is_string() || value.get_ref<const std::string&>().empty() ||
          value.get_ref<const std::string&>()[0] != '/' ||
          value.get_ref<const std::string&>().find('\0') != std::string::npos) {
        return make_error(at + ": the adapter must be an absolute path (/dev/i2c-N)");
      }
      b.buses[n] = value.get<std::string>();
    }
  }
  return b;
}

}  // namespace contego::bundle
