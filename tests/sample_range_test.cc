// Sample-range passes (SdfParams::range): a range's values, rows and VJP
// partial sums are the full pass's, bit for bit, however the samples are
// split.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "lib/core/exact_sum.h"
#include "lib/core/sensitivity.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

// K contiguous ranges covering [0, n), cut at random points.
std::vector<SampleRange> Split(int64_t n, int k, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<int64_t> cuts = {0, n};
  while (std::ssize(cuts) < k + 1) {
    const int64_t c = 1 + static_cast<int64_t>(rng() % (n - 1));
    if (std::find(cuts.begin(), cuts.end(), c) == cuts.end()) cuts.push_back(c);
  }
  std::sort(cuts.begin(), cuts.end());
  std::vector<SampleRange> ranges;
  for (size_t i = 0; i + 1 < cuts.size(); ++i) {
    ranges.push_back({cuts[i], cuts[i + 1]});
  }
  return ranges;
}

class SampleRangeTest : public ::testing::TestWithParam<SampleSet> {
 protected:
  void SetUp() override {
    auto mesh = ReadMesh(testing::SharedMesh("decimated-knight.off"));
    ASSERT_TRUE(mesh.ok());
    auto ev = SdfEvaluator::Create(*mesh);
    ASSERT_TRUE(ev.ok());
    ev_ = std::move(*ev);
    params_.samples = GetParam();
    params_.rays = 30;
    params_.opposite_points = true;
    auto full = ev_->Compute(params_, {}, &hits_);
    ASSERT_TRUE(full.ok());
    full_ = std::move(*full);
  }
  int64_t samples() const { return std::ssize(full_.values); }

  std::unique_ptr<SdfEvaluator> ev_;
  SdfParams params_;
  SdfResult full_;
  HitTable hits_;
};

TEST_P(SampleRangeTest, ARangesValuesAreTheFullPasses) {
  for (const SampleRange& r : Split(samples(), 3, 1)) {
    SdfParams p = params_;
    p.range = r;
    HitTable hits;
    auto part = ev_->Compute(p, {.threads = 1}, &hits);
    ASSERT_TRUE(part.ok()) << part.status();
    const int64_t n = r.end - r.begin;
    ASSERT_EQ(std::ssize(part->values), n);
    for (int64_t i = 0; i < n; ++i) {
      const int64_t s = r.begin + i;
      EXPECT_EQ(std::memcmp(&part->values[i], &full_.values[s], 8), 0) << s;
      EXPECT_EQ(part->status[i], full_.status[s]);
      EXPECT_EQ(part->hits[i], full_.hits[s]);
      EXPECT_EQ(part->kept[i], full_.kept[s]);
      EXPECT_EQ(std::memcmp(&part->opposite[i], &full_.opposite[s], 24), 0);
      EXPECT_TRUE(std::equal(hits.Row(s).begin(), hits.Row(s).end(),
                             hits_.Row(s).begin()));
      EXPECT_TRUE(std::equal(hits.KeptRow(s).begin(), hits.KeptRow(s).end(),
                             hits_.KeptRow(s).begin()));
    }
  }
}

TEST_P(SampleRangeTest, MergedVjpPartialSumsAreTheFullVjpForAnySplit) {
  // A third of the weights 0: each range's VJP leaves those samples out,
  // by their offsets from the range's first.
  std::vector<double> g(samples());
  for (size_t i = 0; i < g.size(); ++i) {
    g[i] = i % 3 == 1 ? 0.0 : std::sin(0.91 * i) * 1e3;
  }
  auto full = ComputeVjp(*ev_, hits_, g);
  ASSERT_TRUE(full.ok());
  for (int k : {1, 2, 3, 7}) {
    ExactSums merged(3 * ev_->mesh().num_vertices());
    std::vector<SampleRange> ranges = Split(samples(), k, 10 + k);
    std::shuffle(ranges.begin(), ranges.end(), std::mt19937(k));
    for (const SampleRange& r : ranges) {
      SdfParams p = params_;
      p.range = r;
      HitTable hits;
      ASSERT_TRUE(ev_->Compute(p, {}, &hits).ok());
      auto part = ComputeVjpSums(
          *ev_, hits,
          absl::MakeConstSpan(g).subspan(r.begin, r.end - r.begin),
          {.threads = k % 2 + 1});
      ASSERT_TRUE(part.ok()) << part.status();
      // Through the wire's form: each sum's Terms.
      for (int64_t j = 0; j < merged.size(); ++j) {
        for (double t : part->Terms(j)) merged.Add(j, t);
      }
    }
    const std::vector<Vec3> vjp = RoundVectors(merged);
    EXPECT_EQ(std::memcmp(vjp.data(), full->data(), vjp.size() * sizeof(Vec3)),
              0)
        << "K = " << k;
  }
}

TEST_P(SampleRangeTest, ARangesJacobianRowsAreTheFullOnes) {
  auto full = ComputeJacobian(*ev_, hits_);
  ASSERT_TRUE(full.ok());
  const SampleRange r{samples() / 3, samples() / 2};
  SdfParams p = params_;
  p.range = r;
  HitTable hits;
  ASSERT_TRUE(ev_->Compute(p, {}, &hits).ok());
  auto part = ComputeJacobian(*ev_, hits);
  ASSERT_TRUE(part.ok());
  ASSERT_EQ(std::ssize(part->row_offsets), r.end - r.begin + 1);
  const int64_t offset = full->row_offsets[r.begin];
  ASSERT_EQ(part->nonzeros(), full->row_offsets[r.end] - offset);
  for (int64_t e = 0; e < part->nonzeros(); ++e) {
    EXPECT_EQ(part->columns[e], full->columns[offset + e]);
    EXPECT_EQ(std::memcmp(&part->values[e], &full->values[offset + e], 24), 0);
  }
}

TEST_P(SampleRangeTest, ARangeOutsideTheMeshIsInvalid) {
  const int64_t n = samples();
  for (SampleRange r : {SampleRange{0, n + 1}, SampleRange{5, 5},
                        SampleRange{7, 3}, SampleRange{-1, 4}}) {
    SdfParams p = params_;
    p.range = r;
    auto result = ev_->Compute(p);
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(result.status().message().find(absl::StrCat(n)),
              std::string::npos)
        << result.status();
  }
}

TEST_P(SampleRangeTest, WeightsMustBeTheRangesOwn) {
  SdfParams p = params_;
  p.range = {2, 10};
  HitTable hits;
  ASSERT_TRUE(ev_->Compute(p, {}, &hits).ok());
  auto vjp = ComputeVjp(*ev_, hits, std::vector<double>(samples(), 1.0));
  EXPECT_EQ(vjp.status().code(), absl::StatusCode::kInvalidArgument);
}

INSTANTIATE_TEST_SUITE_P(Samples, SampleRangeTest,
                         ::testing::Values(SampleSet::kVertices,
                                           SampleSet::kFaces),
                         [](const auto& info) {
                           return std::string(SampleSetName(info.param));
                         });

}  // namespace
}  // namespace meshgauge
