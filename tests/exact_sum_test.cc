#include "lib/core/exact_sum.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "lib/core/row_term.h"
#include "lib/core/table_allocator.h"
#include "tests/smaps.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMin = std::numeric_limits<double>::denorm_min();
constexpr double kMax = std::numeric_limits<double>::max();

double Sum(const std::vector<double>& xs) {
  ExactSum s;
  for (double x : xs) s.Add(x);
  return s.Round();
}

TEST(ExactSumTest, HugeCancellationKeepsTheSmallTerm) {
  EXPECT_EQ(Sum({1e308, 1.0, -1e308}), 1.0);
  EXPECT_EQ(Sum({1e308, 1e308, -1e308, -1e308, 0x1p-1074}), 0x1p-1074);
  EXPECT_EQ(Sum({1.0, 1e100, 1.0, -1e100}), 2.0);
}

TEST(ExactSumTest, SubnormalsAddExactly) {
  EXPECT_EQ(Sum({kMin, kMin, kMin}), 3 * kMin);
  EXPECT_EQ(Sum({0x1p-1022, -kMin}), 0x1p-1022 - kMin);
  EXPECT_EQ(Sum({-kMin, -kMin}), -2 * kMin);
}

TEST(ExactSumTest, ExactZeroIsPositiveZero) {
  const double z = Sum({1.5, -1.5});
  EXPECT_EQ(z, 0.0);
  EXPECT_FALSE(std::signbit(z));
  EXPECT_EQ(Sum({}), 0.0);
  EXPECT_TRUE(ExactSum().IsZero());
}

TEST(ExactSumTest, TiesRoundToEven) {
  // 1 + 2^-53 is halfway between 1 and 1 + 2^-52: even is 1.
  EXPECT_EQ(Sum({1.0, 0x1p-53}), 1.0);
  // 1 + 3 * 2^-53 is halfway between 1 + 2^-52 and 1 + 2^-51: even is the
  // latter.
  EXPECT_EQ(Sum({1.0, 0x1p-53, 0x1p-52}), 1.0 + 0x1p-51);
  // Just over halfway rounds up: the sticky bit.
  EXPECT_EQ(Sum({1.0, 0x1p-53, 0x1p-200}), 1.0 + 0x1p-52);
  EXPECT_EQ(Sum({-1.0, -0x1p-53, -0x1p-200}), -(1.0 + 0x1p-52));
}

TEST(ExactSumTest, OverflowRoundsToInfinityAndBack) {
  EXPECT_EQ(Sum({kMax, kMax}), kInf);
  EXPECT_EQ(Sum({kMax, kMax, -kMax}), kMax);
  EXPECT_EQ(Sum({-kMax, -kMax}), -kInf);
}

TEST(ExactSumTest, NonFiniteInputsAreExplicit) {
  EXPECT_EQ(Sum({1.0, kInf, 5.0}), kInf);
  EXPECT_EQ(Sum({-kInf, 1e308, 1e308}), -kInf);
  EXPECT_TRUE(std::isnan(Sum({kInf, -kInf})));
  EXPECT_TRUE(std::isnan(Sum({1.0, std::nan("")})));
  ExactSum a, b;
  a.Add(kInf);
  b.Add(-kInf);
  a.Add(b);
  EXPECT_TRUE(std::isnan(a.Round()));
  EXPECT_EQ(a.Terms().size(), 1u);
}

// Values over a wide exponent range with both signs.
std::vector<double> WideValues(int n, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> mantissa(-1, 1);
  std::uniform_int_distribution<int> exponent(-300, 300);
  std::vector<double> xs(n);
  for (double& x : xs) x = std::ldexp(mantissa(rng), exponent(rng));
  return xs;
}

TEST(ExactSumTest, OrderAndSplitDoNotChangeTheBits) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    std::vector<double> xs = WideValues(2000, seed);
    const double whole = Sum(xs);
    std::mt19937 rng(seed);
    std::shuffle(xs.begin(), xs.end(), rng);
    EXPECT_EQ(Sum(xs), whole);
    // Split at random points into parts summed on their own, merged in a
    // random order, directly and through their Terms.
    std::vector<size_t> cuts = {0, xs.size()};
    for (int k = 0; k < 6; ++k) cuts.push_back(rng() % xs.size());
    std::sort(cuts.begin(), cuts.end());
    std::vector<ExactSum> parts;
    for (size_t i = 0; i + 1 < cuts.size(); ++i) {
      ExactSum part;
      for (size_t j = cuts[i]; j < cuts[i + 1]; ++j) part.Add(xs[j]);
      parts.push_back(part);
    }
    std::shuffle(parts.begin(), parts.end(), rng);
    ExactSum merged, from_terms;
    for (const ExactSum& part : parts) {
      merged.Add(part);
      for (double t : part.Terms()) from_terms.Add(t);
    }
    EXPECT_EQ(merged.Round(), whole) << "seed " << seed;
    EXPECT_EQ(from_terms.Round(), whole) << "seed " << seed;
  }
}

TEST(ExactSumTest, TermsAreShortAndCanonical) {
  ExactSum s;
  s.Add(1.0);
  s.Add(0x1p-60);
  s.Add(0x1p-130);
  const std::vector<double> terms = s.Terms();
  ASSERT_EQ(terms.size(), 3u);
  EXPECT_EQ(terms[0], 1.0);
  EXPECT_EQ(terms[1], 0x1p-60);
  EXPECT_EQ(terms[2], 0x1p-130);
  ExactSum other;  // the same value, added another way.
  other.Add(0x1p-130);
  other.Add(2.0);
  other.Add(0x1p-60);
  other.Add(-1.0);
  EXPECT_EQ(other.Terms(), terms);
}

TEST(ExactSumTest, ManyLargeAdditionsCancelExactly) {
  ExactSum s;
  const int n = (1 << 20) + 3;
  for (int i = 0; i < n; ++i) s.Add(kMax);
  EXPECT_EQ(s.Round(), kInf);
  for (int i = 0; i < n; ++i) s.Add(-kMax);
  EXPECT_EQ(s.Round(), 0.0);
}

// ExactSums against the reference ExactSum, index by index: the values of
// WideValues (most additions spill), values within 2^40 of each other (none
// should), cancellations, overflows and non-finite inputs, in two orders,
// spread over 16 sums and all in one (where a pair overflows or meets a
// non-finite value and must leave it for the exact accumulator).
TEST(ExactSumsTest, EverySumIsTheReferencesWhicheverPathItTook) {
  std::vector<std::vector<double>> inputs = {WideValues(400, 7),
                                             WideValues(400, 8),
                                             {1.0, 0x1p-70, 0x1p-140},
                                             {kMax, kMax, -kMax},
                                             {1e300, -1e300, 3.0},
                                             {kMin, kMin, -kMin},
                                             {kInf, 1.0},
                                             {kInf, -kInf},
                                             {std::nan(""), 2.0},
                                             {-0.0},
                                             {},
                                             {kMax, kMax},
                                             {-kMax, -kMax, 1.0},
                                             {kMax, kMax, -kMax, -kMax},
                                             {1.0, kInf, 2.0},
                                             {kMax, 0x1p-1074, kMax, -kMax},
                                             {std::nan(""), kMax}};
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(-1, 1);
  std::vector<double> narrow(800);
  for (double& x : narrow) x = std::ldexp(unit(rng), static_cast<int>(rng() % 40));
  inputs.push_back(narrow);
  for (const int sums : {16, 1}) {
    for (size_t k = 0; k < inputs.size(); ++k) {
      for (bool reversed : {false, true}) {
        std::vector<double> xs = inputs[k];
        if (reversed) std::reverse(xs.begin(), xs.end());
        ExactSums fast(sums);
        std::vector<ExactSum> reference(sums);
        for (size_t j = 0; j < xs.size(); ++j) {
          fast.Add(j % sums, xs[j]);
          reference[j % sums].Add(xs[j]);
        }
        for (int i = 0; i < sums; ++i) {
          const double want = reference[i].Round();
          if (std::isnan(want)) {
            EXPECT_TRUE(std::isnan(fast.Round(i))) << "input " << k;
            continue;
          }
          EXPECT_EQ(std::bit_cast<uint64_t>(fast.Round(i)),
                    std::bit_cast<uint64_t>(want))
              << "input " << k << " of " << sums << " sums, sum " << i;
          if (std::isfinite(want)) {
            ExactSum again;
            for (double t : fast.Terms(i)) again.Add(t);
            EXPECT_EQ(again.Round(), want) << "input " << k << " sum " << i;
            EXPECT_LE(fast.Terms(i).size(), reference[i].Terms().size() + 1);
          }
        }
      }
    }
  }
}

// AddScaledTerms against Add, term by term and component by component, in
// both instruction sets: rows over six vertices (repeats included) of
// terms whose components are near their sums' magnitudes (the vector path),
// far from them (a lane whose pair cannot hold the sum: x, y or z alone),
// -0, overflowing with g, or not finite, scaled by weights of every sign and
// scale; every sum's rounding and terms (the state left for Round, Terms
// and later additions) and its pair's bytes must be Add's after each of 40
// rows.
TEST(ExactSumsTest, AddScaledTermsGivesTheBitsOfAddForEachComponent) {
  constexpr int kVertices = 6;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1, 1);
  auto component = [&]() -> double {
    switch (rng() % 12) {
      case 0:
        return std::ldexp(unit(rng), static_cast<int>(rng() % 2000) - 1000);
      case 1:
        return -0.0;
      case 2:
        return rng() % 2 ? kInf : -kInf;
      case 3:
        return rng() % 50 == 0 ? std::nan("") : kMax;
      default:
        return std::ldexp(unit(rng), static_cast<int>(rng() % 20));
    }
  };
  // avx = true takes the baseline's path too on a CPU without AVX.
  for (const bool avx : {true, false}) {
    for (const double g : {1.0, -0.7, 0.0, -0.0, 1e300, 0x1p-600}) {
      // 40 rows one after the other into the same sums, from 1, 2, 3, ...
      ExactSums scattered(3 * kVertices), added(3 * kVertices);
      for (int i = 0; i < 3 * kVertices; ++i) {
        scattered.Add(i, 1.0 + i);
        added.Add(i, 1.0 + i);
      }
      for (int row_count = 0; row_count < 40; ++row_count) {
        std::vector<RowTerm> row(rng() % 12);
        for (RowTerm& t : row) {
          t.vertex = static_cast<int32_t>(rng() % kVertices);
          t.d = {component(), component(), component()};
        }
        scattered.AddScaledTerms(row, g, avx);
        for (const RowTerm& t : row) {
          const int64_t o = 3 * int64_t{t.vertex};
          added.Add(o, t.d.x * g);
          added.Add(o + 1, t.d.y * g);
          added.Add(o + 2, t.d.z * g);
        }
        // The pairs themselves (two doubles a sum), bit for bit.
        EXPECT_EQ(std::memcmp(scattered.storage(), added.storage(),
                              3 * kVertices * 2 * sizeof(double)),
                  0)
            << "avx " << avx << " g " << g << " row " << row_count;
        for (int i = 0; i < 3 * kVertices; ++i) {
          EXPECT_EQ(testing::Bits(scattered.Round(i)),
                    testing::Bits(added.Round(i)))
              << "avx " << avx << " g " << g << " row " << row_count << " sum "
              << i;
          EXPECT_TRUE(testing::SameBits(scattered.Terms(i), added.Terms(i)))
              << "avx " << avx << " row " << row_count << " sum " << i;
        }
      }
    }
  }
}

// Sums whose values stay within 2^40 of each other hold in two doubles and
// still round exactly: checked against the reference on 3,000 additions.
TEST(ExactSumsTest, NarrowValuesStayInTwoDoublesAndRoundExactly) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  ExactSums fast(1);
  ExactSum reference;
  for (int j = 0; j < 3000; ++j) {
    const double x = std::ldexp(unit(rng), static_cast<int>(rng() % 40) - 20);
    fast.Add(0, x);
    reference.Add(x);
  }
  EXPECT_EQ(fast.Round(0), reference.Round());
  EXPECT_LE(fast.Terms(0).size(), 2u);
}

// A VJP makes a fresh ExactSums of 48 bytes a vertex: a large one is
// advised for huge pages (TableAllocator), as 4 KiB pages cost about 12 us
// each to fault in here (a million vertices: 0.14 s a VJP). Also run with
// glibc.malloc.hugetlb=0 (CTest's table_allocator_hugetlb_off) and in the
// sanitize stage, where it must not be.
TEST(ExactSumsTest, ALargeArrayOfSumsIsAdvisedForHugePagesUnlessTurnedOff) {
  const std::string mode = testing::ThpMode();
  if (mode.empty() || mode == "never") {
    GTEST_SKIP() << "no transparent huge pages (mode '" << mode << "')";
  }
  const bool expected =
      kTableMapsLargeArrays && !testing::TunablesName("glibc.malloc.hugetlb=0");
  ExactSums sums(int64_t{3} << 20);  // 48 MiB.
  sums.Add(sums.size() - 1, 0.5);
  const testing::Mapping m = testing::MappingAt(sums.storage());
  ASSERT_TRUE(m.found);
  EXPECT_EQ(m.advised, expected);
  EXPECT_EQ(sums.Round(sums.size() - 1), 0.5);
  EXPECT_EQ(sums.Round(0), 0.0);
}

}  // namespace
}  // namespace meshgauge
