#include "cli/user_spec.h"

#include <grp.h>
#include <pwd.h>

#include <fmt/core.h>

namespace contego::cli {
namespace {

bool all_digits(const std::string& s) {
  if (s.empty() || s.size() > 9) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

}  // namespace

Result<UserSpec> parse_user_spec(const std::string& spec) {
  const size_t colon = spec.find(':');
  const std::string user = spec.substr(0, colon);
  const std::string group = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (user.empty() || (colon != std::string::npos && group.empty())) {
    return make_error(fmt::format("--user {}: expected USER or USER:GROUP", spec));
  }
  UserSpec out;
  const passwd* pw =
      all_digits(user) ? getpwuid(static_cast<uid_t>(std::stoul(user))) : getpwnam(user.c_str());
  if (pw == nullptr && !all_digits(user)) {
    return make_error(fmt::format("--user {}: no user '{}' on this host", spec, user));
  }
  out.uid = pw != nullptr ? pw->pw_uid : static_cast<uid_t>(std::stoul(user));
  if (!group.empty()) {
    const struct group* gr = all_digits(group) ? getgrgid(static_cast<gid_t>(std::stoul(group)))
                                               : getgrnam(group.c_str());
    if (gr == nullptr && !all_digits(group)) {
      return make_error(fmt::format("--user {}: no group '{}' on this host", spec, group));
    }
    out.gid = gr != nullptr ? gr->gr_gid : static_cast<gid_t>(std::stoul(group));
    out.groups = {out.gid};
    return out;
  }
  if (pw == nullptr) {
    return make_error(
        fmt::format("--user {}: uid {} has no entry on this host: give its group as {}:GROUP", spec,
                    user, user));
  }
  out.gid = pw->pw_gid;
  int n = 64;
  std::vector<gid_t> groups(static_cast<size_t>(n));
  if (getgrouplist(pw->pw_name, pw->pw_gid, groups.data(), &n) < 0) {
    groups.resize(static_cast<size_t>(n));
    if (getgrouplist(pw->pw_name, pw->pw_gid, groups.data(), &n) < 0) n = 0;
  }
  groups.resize(static_cast<size_t>(n));
  out.groups = groups.empty() ? std::vector<gid_t>{out.gid} : groups;
  return out;
}

}  // namespace contego::cli
