// The public headers must compile cleanly under -Wshadow -Werror in any
// include order. GCC 12 reports a scoped enumerator as shadowing a
// namespace-scope constant of the same name declared earlier, so no
// enumerator of verdict.h may share its name with a constant of
// transaction.h or image.h (they once did: Reason::kUnknownTask vs
// kUnknownTask, RuleKind::kNone vs kNone). Building this file is the test.
#include "contego/core/transaction.h"
// clang-format off: the order is the point
#include "contego/core/checker.h"
#include "contego/core/image.h"
#include "contego/core/verdict.h"
// clang-format on

#include <gtest/gtest.h>

namespace contego::core {
namespace {

TEST(HeaderOrder, NamespaceConstantsAndEnumeratorsAreDistinct) {
  // Both spellings are usable side by side, with their own values.
  EXPECT_EQ(kNoTask, 0xFFFF);
  EXPECT_EQ(static_cast<int>(Reason::kUnknownTask), 11);
  EXPECT_EQ(kNone, 0xFFFF);
  EXPECT_EQ(static_cast<int>(RuleKind::kNoRule), 0);
}

}  // namespace
}  // namespace contego::core
