// `contego reload`: the monitor's policy replaced in place, sessions kept.
// Granted to root and the monitor's own uid only, never on a task's session
// nor to a supervised program or its descendants (Server::message_refusal);
// every refusal is audited.
#include <errno.h>
#include <unistd.h>

#include <fmt/core.h>

#include "base/errorf.h"
#include "monitor/server.h"

namespace contego::monitor {

namespace wire = gate::wire;

wire::Type Server::reload(Session& s, std::span<const uint8_t> payload) {
  const uid_t uid = s.conn->uid;
  auto refuse = [&](int err, const std::string& why) {
    audit_.event("reload-refused", fmt::format("pid {} uid {}: {}", s.conn->pid, uid, why));
    s.out = wire::encode_error({err, why});
    return wire::Type::kError;
  };
  wire::ReloadRequest request;
  if (Status st = wire::decode_reload(payload, &request); !st.ok())
    return refuse(EPROTO, st.error());
  if (Status st = message_refusal(s, wire::Type::kReload); !st.ok()) {
    return refuse(EPERM, st.error());
  }
  if (uid != 0 && uid != geteuid()) {
    return refuse(
        EPERM, fmt::format("only root or the monitor's uid ({}) may reload its policy", geteuid()));
  }
  if (!reloader_) return refuse(ENOTSUP, "this monitor cannot reload its policy");
  const ReloadAnswer answer = reloader_(request, uid);
  if (answer.err != 0) return refuse(answer.err, answer.text + "; the running policy stays");
  s.out.assign(answer.text.begin(), answer.text.end());
  return wire::Type::kReloadOk;
}

Result<std::string> Server::apply_reload(
    std::map<std::string, uint16_t> tasks, std::map<std::string, TaskBinding> bindings,
    std::string source, std::string image_sha256,
    const std::function<Result<std::string>()>& monitor_reload) {
  base::MutexLock lock(mu_);
  for (const auto& [name, id] : tasks_) {
    const auto live = live_sessions_.find(id);
    if (live == live_sessions_.end() || live->second == 0) continue;
    const auto now = tasks.find(name);
    if (now == tasks.end()) {
      return errorf(
          "task {} has {} live session(s) and the new policy has no "
          "such task: stop them first",
          name, live->second);
    }
    if (now->second != id) {
      return errorf(
          "task {} has {} live session(s) and would move from id {} to {}: keep the order of the "
          "policy's tasks (add new ones at the end), or stop them first",
          name, live->second, id, now->second);
    }
  }
  Result<std::string> done = monitor_reload();
  if (!done.ok()) return done;
  tasks_ = std::move(tasks);
  bindings_ = std::move(bindings);
  policy_source_ = std::move(source);
  image_sha256_ = std::move(image_sha256);
  return done;
}

}  // namespace contego::monitor
