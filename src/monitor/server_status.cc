// `contego status`: the monitor's state for an operator, as JSON. Answered
// to root, the monitor's own uid and the status group only, never on a
// task's session nor to a supervised program or its descendants
// (Server::message_refusal).
#include <errno.h>
#include <unistd.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "base/clock.h"
#include "monitor/server.h"

namespace contego::monitor {

namespace wire = gate::wire;

wire::Type Server::status(Session& s) {
  auto refuse = [&](const std::string& why) {
    client_event(s.conn->uid, "request-refused",
                 fmt::format("pid {} uid {}: status: {}", s.conn->pid, s.conn->uid, why));
    s.out = wire::encode_error({EPERM, why});
    return wire::Type::kError;
  };
  if (Status st = message_refusal(s, wire::Type::kStatus); !st.ok()) return refuse(st.error());
  if (s.conn->uid != 0 && s.conn->uid != geteuid() && !s.conn->status_group) {
    return refuse("only root, the monitor's uid or the status group may read its status");
  }
  const std::string text = status_json();
  s.out.assign(text.begin(), text.end());
  return wire::Type::kStatusOk;
}

std::string Server::status_json() {
  nlohmann::json j = nlohmann::json::parse(monitor_.status_json());
  j["pid"] = getpid();
  j["uptime_s"] = (monotonic_us() - started_us_) / 1000000u;
  {
    base::MutexLock lock(mu_);
    j["policy"] = policy_source_;
    j["image_sha256"] = image_sha256_;
    for (auto& t : j["tasks"]) {
      const auto id = t["id"].get<uint16_t>();
      const auto live = live_sessions_.find(id);
      t["sessions"] = live == live_sessions_.end() ? 0u : live->second;
    }
  }
  j["audit"] = {{"path", audit_.path()},
                {"position", audit_.position()},
                {"records", audit_.lines()},
                {"failures", audit_.failures()},
                {"last_hash", audit_.last_hash()}};
  return j.dump();
}

}  // namespace contego::monitor
