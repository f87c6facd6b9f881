// The Morton order the ray pass visits vertices in: a permutation that
// follows the Z-curve whatever order the points came in.
#include "lib/core/spatial_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

namespace meshgauge {
namespace {

TEST(SpatialOrderTest, ScrambledGridIsVisitedAlongTheZCurve) {
  // The corners of a cube, x fastest, then y, then z: the Z-curve's order.
  std::vector<Vec3> corners;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) corners.push_back(Vec3(x, y, z));
  std::vector<int32_t> scramble(8);
  std::iota(scramble.begin(), scramble.end(), 0);
  std::shuffle(scramble.begin(), scramble.end(), std::mt19937(3));
  std::vector<Vec3> points;
  for (int32_t i : scramble) points.push_back(corners[i]);
  const std::vector<int32_t> order = MortonOrder(points);
  ASSERT_EQ(order.size(), 8u);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(scramble[order[k]], k);
}

TEST(SpatialOrderTest, IsAPermutationWithTiesInIndexOrder) {
  std::vector<Vec3> points(1000, Vec3(1, 2, 3));  // all in one cell.
  points[500] = Vec3(-5, 0, 0);
  const std::vector<int32_t> order = MortonOrder(points);
  EXPECT_EQ(order[0], 500);
  for (int k = 1; k < 1000; ++k) EXPECT_EQ(order[k], k <= 500 ? k - 1 : k);
  EXPECT_TRUE(MortonOrder({}).empty());
}

}  // namespace
}  // namespace meshgauge
