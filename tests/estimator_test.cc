// SPEC §5 filter and weights on given distances, and the kappa = 0 rule of
// SPEC v2 §7.
#include "lib/core/estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace meshgauge {
namespace {

std::vector<ConeRay> UnitWeights(int n) {
  std::vector<ConeRay> cone(n);
  for (ConeRay& r : cone) r.weight = 1;
  return cone;
}

ConeEstimate Estimate(const std::vector<double>& t, double kappa,
                      std::vector<uint8_t>& kept) {
  const auto cone = UnitWeights(static_cast<int>(t.size()));
  kept.assign(t.size(), 0);
  std::vector<double> scratch;
  return EstimateCone(t, cone, kappa, absl::MakeSpan(kept), scratch);
}

TEST(EstimatorTest, KappaZeroWithAnEvenCountKeepsTheTwoMiddleDistances) {
  std::vector<uint8_t> kept;
  const ConeEstimate e = Estimate({1.0, 4.0, 2.0, 3.0}, 0, kept);
  EXPECT_EQ(e.kept, 2);
  EXPECT_EQ(e.value, 2.5);
  EXPECT_EQ(kept, (std::vector<uint8_t>{0, 0, 1, 1}));
}

TEST(EstimatorTest, KappaZeroKeepsTheRaysEqualToTheMedian) {
  std::vector<uint8_t> kept;
  const ConeEstimate odd = Estimate({1.0, 2.0, 7.0, 2.0, 9.0}, 0, kept);
  EXPECT_EQ(odd.kept, 2);
  EXPECT_EQ(odd.value, 2.0);
  // Even count whose middle distances are equal: those (and no others).
  const ConeEstimate even = Estimate({1.0, 2.0, 2.0, 9.0}, 0, kept);
  EXPECT_EQ(even.kept, 2);
  EXPECT_EQ(even.value, 2.0);
}

TEST(EstimatorTest, MissesAreIgnoredAndNoHitKeepsNothing) {
  std::vector<uint8_t> kept;
  const double nan = std::nan("");
  EXPECT_EQ(Estimate({nan, nan}, 1, kept).kept, 0);
  const ConeEstimate e = Estimate({nan, 3.0, nan, 5.0}, 0, kept);
  EXPECT_EQ(e.hits, 2);
  EXPECT_EQ(e.kept, 2);
  EXPECT_EQ(e.value, 4.0);
}

}  // namespace
}  // namespace meshgauge
