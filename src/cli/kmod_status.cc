#include "cli/kmod_status.h"

#include <errno.h>

#include <cstring>
#include <fmt/core.h>
#include <linux/contego_kmod.h>
#include <string_view>
#include <sys/ioctl.h>

#include "monitor/metrics.h"
#include "monitor/sha256.h"

namespace contego::cli {

// The image in force in the module, read back (CONTEGO_KMOD_IMAGE), and its CRC.
Result<std::pair<std::vector<uint8_t>, uint32_t>> running_image(int fd) {
  contego_kmod_image req{};
  std::vector<uint8_t> bytes;
  for (int attempt = 0; attempt < 3; ++attempt) {  // a load between two asks: ask again
    req.buf = reinterpret_cast<uintptr_t>(bytes.data());
    req.size = static_cast<uint32_t>(bytes.size());
    if (::ioctl(fd, CONTEGO_KMOD_IMAGE, &req) == 0) {
      bytes.resize(req.size);
      return std::pair{std::move(bytes), req.crc};
    }
    if (errno == ENOENT) {
      return make_error("no policy is in force in the module: load one with `contego kmod load`");
    }
    if (errno == ENOTTY) {
      return make_error(
          "the module predates loads in place (no CONTEGO_KMOD_IMAGE): load the contego.ko built "
          "with this contego, or `contego kmod load` (every device driven to its safe state)");
    }
    if (errno != ENOSPC)
      return make_error(std::string("reading the image back: ") + strerror(errno));
    bytes.resize(req.size);
  }
  return make_error("the module's image kept changing while it was read back");
}

// The devices of `mask` (bit d: device d), named from the image.
std::string devices_named(const image::ImageModel& model, uint32_t mask) {
  std::string out;
  for (uint32_t d = 0; d < 32; ++d) {
    if ((mask & (1u << d)) == 0) continue;
    out += out.empty() ? "" : ", ";
    if (d < model.devices.size()) {
      const auto& dev = model.devices[d];
      out += fmt::format("{} (i2c-{} 0x{:02x})", dev.name, dev.record.bus, dev.record.addr);
    } else {
      out += fmt::format("device {}", d);
    }
  }
  return out;
}

Result<nlohmann::ordered_json> kmod_status(int fd) {
  contego_kmod_stats s{};
  if (::ioctl(fd, CONTEGO_KMOD_STATS, &s) != 0) {
    return make_error(fmt::format("stats: {}", std::strerror(errno)));
  }
  nlohmann::ordered_json j;
  j["loaded"] = s.loaded != 0;
  auto running = s.loaded ? running_image(fd) : make_error("no policy is in force");
  image::ImageModel model;  // the image in force's names, when it can be read
  if (running.ok()) {
    const auto& bytes = running->first;
    j["image_sha256"] = monitor::sha256_hex(
        std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    j["image_crc32"] = fmt::format("{:08x}", running->second);
    j["image_bytes"] = bytes.size();
    if (auto m = image::deserialize(bytes); m.ok()) {
      model = std::move(*m);
      j["tasks"] = nlohmann::ordered_json::array();
      for (const auto& t : model.tasks) j["tasks"].push_back(t.name);
      j["devices"] = nlohmann::ordered_json::array();
      for (size_t d = 0; d < model.devices.size(); ++d) {
        const auto& dev = model.devices[d];
        const uint32_t bit = d < 32 ? 1u << d : 0;
        j["devices"].push_back({{"name", dev.name},
                                {"bus", dev.record.bus},
                                {"addr", fmt::format("0x{:02x}", dev.record.addr)},
                                {"latched", (s.latched & bit) != 0},
                                {"undriven", (s.undriven & bit) != 0},
                                {"unread", (s.unread & bit) != 0}});
      }
    }
  } else if (s.loaded) {
    j["image_error"] = running.error();  // a module that predates CONTEGO_KMOD_IMAGE
  }
  // A load with --allow-degraded: what it could not do, until it is done.
  std::string degraded;
  if (s.undriven != 0) {
    degraded = fmt::format("the safe state of {} not driven since the load",
                           devices_named(model, s.undriven));
  }
  if (s.unread != 0) {
    degraded += fmt::format("{}{} not read since the load", degraded.empty() ? "" : "; ",
                            devices_named(model, s.unread));
  }
  j["degraded"] = degraded;
  j["latched"] = s.latched != 0 ? devices_named(model, s.latched) : "";
  j["audit_reader"] = s.reader != 0;
  j["counters"] = {{"loads", s.loads},
                   {"refused_loads", s.refused_loads},
                   {"checks", s.checks},
                   {"performed", s.performed},
                   {"refused", s.refused},
                   {"ignored", s.ignored},
                   {"failsafe", s.failsafe},
                   {"holds", s.holds},
                   {"inexpressible", s.inexpressible},
                   {"records", s.records},
                   {"unrecorded", s.unrecorded},
                   {"audit_refused", s.audit_refused},
                   {"sessions", s.sessions},
                   {"session_ends", s.session_ends},
                   {"sessions_refused", s.sessions_refused},
                   {"sessions_limited", s.sessions_limited},
                   {"samples", s.samples},
                   {"sample_errors", s.sample_errors}};
  return j;
}

std::string kmod_metrics_text(const nlohmann::ordered_json& j) {
  std::string out;
  monitor::metrics_family(out, "contego_info", "gauge",
                          "The policy contego.ko enforces (value 1).");
  out += fmt::format("contego_info{{client=\"contego.ko\",image_sha256=\"{}\",loaded=\"{}\"}} 1\n",
                     monitor::metrics_label(j.value("image_sha256", "")),
                     j.value("loaded", false) ? 1 : 0);
  const auto& c = j["counters"];
  // The module's counters, under the names of the monitor's where they mean the same.
  const std::pair<const char*, const char*> counters[] = {
      {"checks", "Transactions checked."},
      {"performed", "Calls that acted on a bus."},
      {"refused", "Calls refused (an errno to the program)."},
      {"ignored", "Calls ignored (success, nothing acted)."},
      {"failsafe", "Calls replaced by a substitute or the safe state."},
      {"holds", "Transfers held over a task's budget."},
      {"inexpressible", "Calls refused: a part had no form on the adapter."},
      {"unrecorded", "Audit records lost (no reader, the ring full)."},
      {"audit_refused", "Calls refused because their record could not be taken."},
      {"session_ends", "Sessions ended (each drove its task's actuators to the safe state)."},
      {"sample_errors", "Sensor samples that failed."},
      {"refused_loads", "Images refused at load."}};
  for (const auto& [key, help] : counters) {
    const std::string name = fmt::format("contego_kmod_{}_total", key);
    monitor::metrics_family(out, name.c_str(), "counter", help);
    out += fmt::format("{} {}\n", name, c.value(key, uint64_t{0}));
  }
  monitor::metrics_family(out, "contego_kmod_sessions", "gauge", "Sessions open now.");
  out += fmt::format("contego_kmod_sessions {}\n", c.value("sessions", uint64_t{0}));
  monitor::metrics_family(out, "contego_kmod_audit_reader", "gauge",
                          "1 while an audit reader is attached.");
  out += fmt::format("contego_kmod_audit_reader {}\n", j.value("audit_reader", false) ? 1 : 0);
  monitor::metrics_family(out, "contego_device_latched", "gauge", "1 while the device is latched.");
  const nlohmann::ordered_json none = nlohmann::ordered_json::array();
  const auto& devices = j.contains("devices") ? j["devices"] : none;
  for (const auto& d : devices) {
    out +=
        fmt::format("contego_device_latched{{device=\"{}\"}} {}\n",
                    monitor::metrics_label(d.value("name", "")), d.value("latched", false) ? 1 : 0);
  }
  monitor::metrics_family(out, "contego_device_unavailable", "gauge",
                          "1: a sensor not read or a safe state not driven since a degraded load.");
  for (const auto& d : devices) {
    for (const auto& [key, what] :
         {std::pair{"unread", "reading"}, std::pair{"undriven", "safe_state"}}) {
      if (!d.value(key, false)) continue;
      out += fmt::format("contego_device_unavailable{{device=\"{}\",what=\"{}\"}} 1\n",
                         monitor::metrics_label(d.value("name", "")), what);
    }
  }
  return out;
}

}  // namespace contego::cli
