// The check that a pass does not depend on the thread count, shared by the
// tests of each method and sample set.
#pragma once

#include <gtest/gtest.h>

#include <cstring>

#include "lib/embree/sdf_evaluator.h"
#include "tests/test_util.h"

namespace meshgauge::testing {

// Computes `params` with 1 and with 2 threads and expects the same values
// (bit for bit, NaN included), statuses, opposite points and hit tables.
// Returns the 2-thread result.
inline SdfResult ExpectSameForOneAndTwoThreads(const SdfEvaluator& ev,
                                               const SdfParams& params) {
  HitTable h1, h2;
  auto r1 = ev.Compute(params, {.threads = 1}, &h1);
  auto r2 = ev.Compute(params, {.threads = 2}, &h2);
  EXPECT_TRUE(r1.ok() && r2.ok());
  if (!r1.ok() || !r2.ok()) return {};
  EXPECT_TRUE(SameBits(r1->values, r2->values));
  EXPECT_EQ(r1->status, r2->status);
  EXPECT_EQ(r1->opposite.size(), r2->opposite.size());
  EXPECT_EQ(std::memcmp(r1->opposite.data(), r2->opposite.data(),
                        r1->opposite.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(h1.primitives, h2.primitives);
  EXPECT_EQ(h1.kept, h2.kept);
  return *std::move(r2);
}

}  // namespace meshgauge::testing
