#include "monitor/metrics.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#include <cstring>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <utility>

#include "base/unique_fd.h"

namespace contego::monitor {

std::string metrics_label(const std::string& v) {
  std::string out;
  for (char c : v) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

void metrics_family(std::string& out, const char* name, const char* type, const char* help) {
  out += fmt::format("# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
}

namespace {

const auto label = metrics_label;
const auto family = metrics_family;

std::string metrics_of(const nlohmann::json& j) {
  std::string out;
  family(out, "contego_info", "gauge", "The policy the monitor enforces (value 1).");
  out += fmt::format("contego_info{{policy=\"{}\",image_sha256=\"{}\",complain=\"{}\"}} 1\n",
                     label(j.value("policy", "")), label(j.value("image_sha256", "")),
                     j.value("complain", false) ? "1" : "0");
  family(out, "contego_uptime_seconds", "gauge", "Seconds since the monitor started serving.");
  out += fmt::format("contego_uptime_seconds {}\n", j.value("uptime_s", 0));
  family(out, "contego_decisions_total", "counter", "Checked commands by task and verdict.");
  for (const auto& t : j["tasks"]) {
    for (const auto& [verdict, n] : t["decisions"].items()) {
      out += fmt::format("contego_decisions_total{{task=\"{}\",verdict=\"{}\"}} {}\n",
                         label(t.value("name", "")), verdict, n.get<uint64_t>());
    }
  }
  family(out, "contego_task_sessions", "gauge", "Live sessions (supervised programs) per task.");
  for (const auto& t : j["tasks"]) {
    out += fmt::format("contego_task_sessions{{task=\"{}\"}} {}\n", label(t.value("name", "")),
                       t.value("sessions", 0));
  }
  family(out, "contego_task_job", "gauge", "The task's current job on its period grid.");
  for (const auto& t : j["tasks"]) {
    out += fmt::format("contego_task_job{{task=\"{}\"}} {}\n", label(t.value("name", "")),
                       t.value("job", 0));
  }
  family(out, "contego_device_latched", "gauge", "1 while the device is latched.");
  for (const auto& d : j["devices"]) {
    out += fmt::format("contego_device_latched{{device=\"{}\"}} {}\n", label(d.value("name", "")),
                       d.value("latched", false) ? 1 : 0);
  }
  family(out, "contego_device_sample_age_seconds", "gauge",
         "Age of the sensor's newest reading (sensors that have one).");
  for (const auto& d : j["devices"]) {
    // null: no reading fresh enough (contego_device_unavailable says so).
    if (!d.contains("sample_age_ms") || !d["sample_age_ms"].is_number()) continue;
    out += fmt::format("contego_device_sample_age_seconds{{device=\"{}\"}} {:.3f}\n",
                       label(d.value("name", "")), d["sample_age_ms"].get<double>() / 1000.0);
  }
  family(out, "contego_device_unavailable", "gauge",
         "1: a sensor without a fresh reading, or a safe state not driven since the start.");
  for (const auto& d : j["devices"]) {
    for (const auto& [key, what] :
         {std::pair{"sample_age_ms", "reading"}, std::pair{"safe_state_age_s", "safe_state"}}) {
      if (!d.contains(key) || !d[key].is_null()) continue;
      out += fmt::format("contego_device_unavailable{{device=\"{}\",what=\"{}\"}} 1\n",
                         label(d.value("name", "")), what);
    }
  }
  family(out, "contego_holds_total", "counter", "Transfers held over a task's budget.");
  out += fmt::format("contego_holds_total {}\n", j.value("holds", 0));
  family(out, "contego_audit_refusals_total", "counter",
         "Transfers refused because their audit record could not be written.");
  out += fmt::format("contego_audit_refusals_total {}\n", j.value("audit_refusals", 0));
  const auto& a = j["audit"];
  family(out, "contego_audit_records_total", "counter", "Audit records written.");
  out += fmt::format("contego_audit_records_total {}\n", a.value("records", 0));
  family(out, "contego_audit_failures_total", "counter",
         "Audit records that could not be written.");
  out += fmt::format("contego_audit_failures_total {}\n", a.value("failures", 0));
  family(out, "contego_audit_bytes", "gauge", "The audit file's size up to its last record.");
  out += fmt::format("contego_audit_bytes {}\n", a.value("position", 0));
  if (j.contains("check_cost")) {
    const auto& c = j["check_cost"];
    family(out, "contego_check_duration_seconds", "histogram",
           "Wall-clock time of deciding a transfer (the core's checks, not the bus I/O).");
    uint64_t cumulative = 0;
    const auto& bounds = c["bounds_ns"];
    const auto& counts = c["counts"];
    for (size_t i = 0; i < counts.size(); ++i) {
      cumulative += counts[i].get<uint64_t>();
      const std::string le =
          i < bounds.size()
              ? fmt::format("{:g}", static_cast<double>(bounds[i].get<uint64_t>()) / 1e9)
              : "+Inf";
      out += fmt::format("contego_check_duration_seconds_bucket{{le=\"{}\"}} {}\n", le, cumulative);
    }
    out += fmt::format("contego_check_duration_seconds_sum {:.9f}\n",
                       static_cast<double>(c.value("sum_ns", uint64_t{0})) / 1e9);
    out += fmt::format("contego_check_duration_seconds_count {}\n", c.value("count", 0));
  }
  return out;
}

}  // namespace

std::string metrics_text(const std::string& status_json) {
  const auto j = nlohmann::json::parse(status_json, nullptr, false);
  if (j.is_discarded()) return {};
  // A field of another type than expected must cost the metrics, never the
  // daemon that decides (a periodic write runs on its own thread).
  try {
    return metrics_of(j);
  } catch (const nlohmann::json::exception& e) {
    return fmt::format("# contego: the status could not be read as metrics: {}\n", e.what());
  }
}

Status write_metrics_file(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  base::UniqueFd fd(
      ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOFOLLOW, 0644));
  if (!fd.valid()) {
    return make_error(
        fmt::format("cannot write the metrics file {}: {}", tmp, std::strerror(errno)));
  }
  size_t off = 0;
  while (off < text.size()) {
    const ssize_t n = ::write(fd.get(), text.data() + off, text.size() - off);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = errno;
      ::unlink(tmp.c_str());
      return make_error(fmt::format("cannot write the metrics file {}: {}", tmp, std::strerror(e)));
    }
    off += static_cast<size_t>(n);
  }
  if (::fsync(fd.get()) != 0 || ::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    return make_error(
        fmt::format("cannot replace the metrics file {}: {}", path, std::strerror(e)));
  }
  return {};
}

}  // namespace contego::monitor
