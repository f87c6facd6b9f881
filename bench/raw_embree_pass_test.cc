// SpecCeiling: the benchmarks' anchor is the fastest ROBUST configuration
// with the no-op filter that misses no hit.
#include "bench/raw_embree_pass.h"

#include <gtest/gtest.h>

#include <vector>

namespace meshgauge::bench {
namespace {

std::vector<RawConfig> Configs() {
  return {
      {.robust = false, .trace = RawTrace::kStream},  // fastest, no filter
      {.robust = true, .trace = RawTrace::kPacket8, .noop_filter = true},
      {.robust = true, .trace = RawTrace::kPacket16, .noop_filter = true},
      {.robust = true, .trace = RawTrace::kStream, .noop_filter = true},
  };
}

TEST(SpecCeilingTest, AConfigurationThatMissesHitsIsNoCeiling) {
  // The stream is the fastest with the filter but hits one ray fewer.
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0, 8.0}, {100, 100, 100, 99}),
            2u);
}

TEST(SpecCeilingTest, TheFastestFilteredConfigurationWithEveryHitIsTheCeiling) {
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0, 8.0}, {100, 100, 100, 100}),
            3u);
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 7.0, 6.0, 5.0}, {100, 100, 100, 100}),
            1u);
}

TEST(SpecCeilingTest, AConfigurationWithoutTheFilterIsNoCeiling) {
  // The unfiltered one hits more rays and is faster: neither makes it the
  // ceiling, nor does it disqualify the filtered ones.
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0, 8.0}, {101, 100, 100, 100}),
            3u);
  EXPECT_EQ(
      SpecCeiling({{.robust = true, .trace = RawTrace::kSingle}}, {1.0}, {10}),
      1u);
}

}  // namespace
}  // namespace meshgauge::bench
