// SummarizeValues: the statistics of the finite values, as the CLI's summary
// and the server's penalty report print them.
#include <cmath>
#include <limits>
#include <vector>

#include "gtest/gtest.h"
#include "lib/core/sdf_types.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::kNaN;
using testing::kInf;


TEST(ValueStatsTest, OddCountHasTheMiddleValueAsMedian) {
  const ValueStats s = SummarizeValues({5, kNaN, 1, 4, 2, 3});
  EXPECT_EQ(s.count, 5);
  EXPECT_EQ(s.min, 1);
  EXPECT_EQ(s.max, 5);
  EXPECT_EQ(s.median, 3);
  EXPECT_EQ(s.mean, 3);
}

TEST(ValueStatsTest, EvenCountAveragesTheTwoMiddleValues) {
  const ValueStats s = SummarizeValues({10, 1, kInf, 7, 2});
  EXPECT_EQ(s.count, 4);
  EXPECT_EQ(s.median, 4.5);
  EXPECT_EQ(s.mean, 5);
}

TEST(ValueStatsTest, MedianOfManyUnsortedValues) {
  std::vector<double> values;
  for (int i = 0; i < 1001; ++i) values.push_back((i * 389) % 1001);
  const ValueStats s = SummarizeValues(values);
  EXPECT_EQ(s.median, 500);
  EXPECT_EQ(s.min, 0);
  EXPECT_EQ(s.max, 1000);
}

TEST(ValueStatsTest, MedianOfManyValuesWithRepeatsAndAnEvenCount) {
  std::vector<double> values;
  for (int i = 0; i < 1000; ++i) values.push_back((i * 389) % 1000 / 2);
  const ValueStats s = SummarizeValues(values);  // 0, 0, 1, 1, ..., 499
  EXPECT_EQ(s.count, 1000);
  EXPECT_EQ(s.median, 249.5);
  EXPECT_EQ(s.mean, 249.5);
}

TEST(ValueStatsTest, NoFiniteValueGivesNaNs) {
  const ValueStats s = SummarizeValues({kNaN, -kInf});
  EXPECT_EQ(s.count, 0);
  EXPECT_TRUE(std::isnan(s.median));
  EXPECT_TRUE(std::isnan(s.mean));
}

}  // namespace
}  // namespace meshgauge
