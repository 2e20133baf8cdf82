// The gtest fixture the core's check tests share: a Harness and `load`, which
// fails the test on a refused image and says which record it refused.
#ifndef CONTEGO_CORE_HARNESS_FIXTURE_TEST_H_
#define CONTEGO_CORE_HARNESS_FIXTURE_TEST_H_

#include <gtest/gtest.h>

#include "core/test_fixtures.h"

namespace contego::core::testing {

class HarnessTest : public ::testing::Test {
 protected:
  void load(const image::ImageModel& m) {
    const LoadResult r = h.load(m);
    ASSERT_EQ(r.status, LoadStatus::kOk)
        << load_status_name(r.status) << " section " << r.section << " index " << r.index;
  }
  Harness h;
};

}  // namespace contego::core::testing

#endif  // CONTEGO_CORE_HARNESS_FIXTURE_TEST_H_
