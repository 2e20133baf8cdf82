// errorf(...): a Status's or Result's error, formatted ({fmt}), for the
// refusals that name what they refuse: `return errorf("pid {} is gone", pid);`.
#ifndef CONTEGO_BASE_ERRORF_H_
#define CONTEGO_BASE_ERRORF_H_

#include <fmt/format.h>
#include <utility>

#include "base/result.h"

namespace contego {

template <typename... Args>
Error errorf(fmt::format_string<Args...> format, Args&&... args) {
  return make_error(fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace contego

#endif  // CONTEGO_BASE_ERRORF_H_
