// SPEC §5 filter and weights on given distances, and the kappa = 0 rule of
// SPEC v2 §7.
#include "lib/core/estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
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

// SelectMiddle against std::nth_element: every count from 1 to 130, values
// in tight clusters with ties (most fall in one bucket), spread ones, and a
// range too small for buckets (hi - lo subnormal: scale overflows) and one
// too large (hi - lo overflows).
TEST(EstimatorTest, SelectMiddleGivesTheValuesOfTheMiddleRanks) {
  std::mt19937 rng(7);
  std::normal_distribution<double> tight(1.0, 1e-3);
  std::uniform_real_distribution<double> spread(0.5, 40.0);
  for (int n = 1; n <= 130; ++n) {
    for (int kind = 0; kind < 5; ++kind) {
      std::vector<double> v(n);
      for (double& x : v) {
        switch (kind) {
          case 0:
            x = rng() % 10 < 7 ? tight(rng) : spread(rng);
            break;
          case 1:
            x = std::round(spread(rng));
            break;  // many ties
          case 2:
            x = 1e-310 * (1 + rng() % 3);
            break;  // subnormal range
          case 3:
            x = (rng() % 2 == 0 ? 1.5e308 : -1.5e308) / (1 + rng() % 3);
            break;
          default:
            x = rng() % 2 == 0 ? 2.0 : 3.0;
        }
      }
      std::vector<double> sorted = v;
      std::sort(sorted.begin(), sorted.end());
      const size_t mid = v.size() / 2;
      const MiddleValues m = SelectMiddle(v, sorted.front(), sorted.back());
      EXPECT_EQ(m.upper, sorted[mid]) << n << " " << kind;
      EXPECT_EQ(m.lower, n % 2 == 0 ? sorted[mid - 1] : sorted[mid])
          << n << " " << kind;
      // Bounds inside the values (a caller's error) clamp the buckets: the
      // same values, no access outside them.
      const MiddleValues inner =
          SelectMiddle(v, sorted[n / 4], sorted[(3 * n) / 4]);
      EXPECT_EQ(inner.upper, m.upper) << n << " " << kind;
      EXPECT_EQ(inner.lower, m.lower) << n << " " << kind;
    }
  }
  std::vector<double> none;
  const MiddleValues empty = SelectMiddle(none, 0, 0);
  EXPECT_EQ(empty.lower, 0);
  EXPECT_EQ(empty.upper, 0);
}

}  // namespace
}  // namespace meshgauge
