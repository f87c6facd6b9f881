// SPEC §9: the closed-form limit of the estimator and its examples.
#include <gtest/gtest.h>

#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::ClosedFormEstimate;

TEST(ClosedFormTest, MatchesSpecExamples) {
  EXPECT_NEAR(ClosedFormEstimate(2, 30, 30), 0.99789, 5e-6);
  EXPECT_NEAR(ClosedFormEstimate(3, 30, 100), 0.98402, 5e-6);
}

}  // namespace
}  // namespace meshgauge
