// `contego run --user USER[:GROUP]`: the credentials the program runs with.
#ifndef CONTEGO_CLI_USER_SPEC_H_
#define CONTEGO_CLI_USER_SPEC_H_

#include <string>
#include <sys/types.h>
#include <vector>

#include "base/result.h"

namespace contego::cli {

struct UserSpec {
  uid_t uid = 0;
  gid_t gid = 0;
  std::vector<gid_t> groups;  // the user's supplementary groups, or just GROUP when given
};

// USER and GROUP are names or numeric ids. A named user without GROUP gets
// its primary group and its groups from the group database; a numeric one
// without a database entry gets gid = uid's entry or fails.
Result<UserSpec> parse_user_spec(const std::string& spec);

}  // namespace contego::cli

#endif  // CONTEGO_CLI_USER_SPEC_H_
