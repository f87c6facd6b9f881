// SpecCeiling: the benchmarks' anchor is the fastest ROBUST configuration
// with the no-op filter that misses no hit.
#include "bench/raw_embree_pass.h"

#include <gtest/gtest.h>

#include <optional>
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
            std::optional<size_t>(2));
}

TEST(SpecCeilingTest, TheFastestFilteredConfigurationWithEveryHitIsTheCeiling) {
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0, 8.0}, {100, 100, 100, 100}),
            std::optional<size_t>(3));
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 7.0, 6.0, 5.0}, {100, 100, 100, 100}),
            std::optional<size_t>(1));
}

TEST(SpecCeilingTest, AConfigurationWithoutTheFilterIsNoCeiling) {
  // The unfiltered one hits more rays and is faster: neither makes it the
  // ceiling, nor does it disqualify the filtered ones.
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0, 8.0}, {101, 100, 100, 100}),
            std::optional<size_t>(3));
}

TEST(SpecCeilingTest, AFilteredPlainSceneIsNoCeiling) {
  // Not watertight: neither the ceiling nor, by hitting more rays, a
  // reason to leave out the ROBUST ones.
  std::vector<RawConfig> configs = Configs();
  configs.push_back(
      {.robust = false, .trace = RawTrace::kPacket16, .noop_filter = true});
  EXPECT_EQ(SpecCeiling(configs, {9.0, 5.0, 6.0, 8.0, 10.0},
                        {100, 100, 100, 100, 101}),
            std::optional<size_t>(3));
}

TEST(SpecCeilingTest, NoRobustFilteredConfigurationGivesNoCeiling) {
  EXPECT_EQ(
      SpecCeiling(
          {{.robust = true, .trace = RawTrace::kSingle},
           {.robust = false, .trace = RawTrace::kSingle, .noop_filter = true}},
          {1.0, 2.0}, {10, 10}),
      std::nullopt);
}

TEST(SpecCeilingTest, SpansOfAnotherSizeGiveNoCeiling) {
  EXPECT_EQ(SpecCeiling(Configs(), {9.0, 5.0, 6.0}, {100, 100, 100, 100}),
            std::nullopt);
}

}  // namespace
}  // namespace meshgauge::bench
