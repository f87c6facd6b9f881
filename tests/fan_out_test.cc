// The fan-out (client/remote/fan_out.h): one call split into K sample
// ranges, sent at once and merged, is the whole call, bit for bit, for any
// K and whichever server computes which range.
#include "client/remote/fan_out.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "lib/core/face_sample.h"
#include "lib/core/penalty.h"
#include "lib/io/mesh_io.h"
#include "tests/server_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

template <typename T>
bool SameBytes(const std::vector<T>& a, const std::vector<T>& b) {
  // memcmp may not be given the null data() of an empty vector.
  return a.size() == b.size() &&
         (a.empty() ||
          std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void ExpectSameReply(const wire::SdfReply& a, const wire::SdfReply& b) {
  const SdfResult& x = a.result;
  const SdfResult& y = b.result;
  EXPECT_TRUE(SameBytes(x.values, y.values));
  EXPECT_TRUE(SameBytes(x.normalized, y.normalized));
  EXPECT_EQ(x.status, y.status);
  EXPECT_EQ(x.hits, y.hits);
  EXPECT_EQ(x.kept, y.kept);
  EXPECT_TRUE(SameBytes(x.opposite, y.opposite));
  EXPECT_EQ(x.rays_traced, y.rays_traced);
  EXPECT_EQ(x.world_frame_vertices, y.world_frame_vertices);
  EXPECT_EQ(x.missing.vertices, y.missing.vertices);
  EXPECT_EQ(x.missing.faces, y.missing.faces);
  EXPECT_EQ(std::bit_cast<uint64_t>(x.missing.area_fraction),
            std::bit_cast<uint64_t>(y.missing.area_fraction));
  EXPECT_EQ(std::bit_cast<uint64_t>(a.integral),
            std::bit_cast<uint64_t>(b.integral));
  ASSERT_EQ(a.jacobian.has_value(), b.jacobian.has_value());
  if (a.jacobian) {
    EXPECT_EQ(a.jacobian->row_offsets, b.jacobian->row_offsets);
    EXPECT_EQ(a.jacobian->columns, b.jacobian->columns);
    EXPECT_TRUE(SameBytes(a.jacobian->values, b.jacobian->values));
  }
}

class FanOutTest : public testing::ServerFixture {
 protected:
  void SetUp() override {
    StartServer();
    mesh_ = *ReadMesh(testing::SharedMesh("decimated-knight.off"));
    ASSERT_TRUE(client_->Upload(mesh_, "knight").ok());
  }
  std::vector<double> Weights(int64_t n) const {
    std::vector<double> g(n);
    for (int64_t i = 0; i < n; ++i) g[i] = std::cos(0.37 * i) * 10;
    return g;
  }
  Mesh mesh_;
};

TEST_F(FanOutTest, FannedOutSdfAndVjpAreTheWholeCallsForAnyK) {
  for (SampleSet samples : {SampleSet::kVertices, SampleSet::kFaces}) {
    SdfParams params;
    params.rays = 40;
    params.samples = samples;
    params.opposite_points = true;
    auto whole =
        client_->ComputeSdf("knight", params, {.include_jacobian = true});
    ASSERT_TRUE(whole.ok()) << whole.status();
    const std::vector<double> g = Weights(NumSamples(mesh_, samples));
    auto whole_vjp = client_->ComputeVjp("knight", params, g);
    ASSERT_TRUE(whole_vjp.ok()) << whole_vjp.status();
    for (int k : {1, 2, 3, 7}) {
      SCOPED_TRACE(::testing::Message() << SampleSetName(samples) << " K " << k);
      auto fanned = client_->ComputeSdf(
          "knight", params,
          {.include_jacobian = true, .fan_out = k, .mesh = &mesh_});
      ASSERT_TRUE(fanned.ok()) << fanned.status();
      ExpectSameReply(*fanned, *whole);
      auto vjp = client_->ComputeVjp("knight", params, g, std::nullopt, k);
      ASSERT_TRUE(vjp.ok()) << vjp.status();
      EXPECT_TRUE(SameBytes(vjp->gradient, whole_vjp->gradient));
    }
  }
}

// A fanned-out penalty (every range sent with every sample's value) is the
// whole call's: value, missing counts, sdf_min, frame fallbacks and
// gradient, bit for bit, for each form and sample set and any K.
TEST_F(FanOutTest, FannedOutPenaltyIsTheWholeCallForAnyK) {
  for (SampleSet samples : {SampleSet::kVertices, SampleSet::kFaces}) {
    SdfParams params;
    params.rays = 40;
    params.samples = samples;
    auto sdf = client_->ComputeSdf("knight", params);
    ASSERT_TRUE(sdf.ok()) << sdf.status();
    std::vector<double> sorted = sdf->result.values;
    std::sort(sorted.begin(), sorted.end());
    for (PenaltyForm form : {PenaltyForm::kOneSided, PenaltyForm::kKs}) {
      // Half the samples below t_min.
      const PenaltyParams penalty{.t_min = sorted[sorted.size() / 2],
                                  .form = form};
      auto whole = client_->ComputePenalty("knight", params, penalty, true);
      ASSERT_TRUE(whole.ok()) << whole.status();
      for (int k : {2, 3, 7}) {
        SCOPED_TRACE(::testing::Message() << SampleSetName(samples) << " "
                                          << PenaltyFormName(form) << " K "
                                          << k);
        auto fanned = client_->ComputePenalty("knight", params, penalty, true,
                                              std::nullopt, k,
                                              sdf->result.values);
        ASSERT_TRUE(fanned.ok()) << fanned.status();
        EXPECT_EQ(std::bit_cast<uint64_t>(fanned->penalty.value),
                  std::bit_cast<uint64_t>(whole->penalty.value));
        EXPECT_EQ(fanned->penalty.missing.faces, whole->penalty.missing.faces);
        EXPECT_EQ(fanned->sdf_min, whole->sdf_min);
        EXPECT_EQ(fanned->world_frame_vertices, whole->world_frame_vertices);
        EXPECT_TRUE(SameBytes(fanned->penalty.gradient, whole->penalty.gradient));
      }
    }
  }
  // Without the values a fanned-out penalty is refused before any call.
  EXPECT_EQ(client_->ComputePenalty("knight", {}, {.t_min = 1}, true,
                                    std::nullopt, 2)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

// Ranges on two servers holding the same session, in a shuffled order and
// assignment, merge to the whole call.
TEST_F(FanOutTest, RangesOnTwoServersInAnyOrderMergeToTheWholeCall) {
  server::Metrics other_metrics;
  auto other = server::MeshGaugeServer::Start(options_, &other_metrics, &clock_);
  ASSERT_TRUE(other.ok()) << other.status();
  client::RemoteClient other_client("127.0.0.1:" +
                                    std::to_string((*other)->port()));
  ASSERT_TRUE(other_client.Upload(mesh_, "knight").ok());
  client::RemoteClient* clients[] = {client_.get(), &other_client};
  SdfParams params;
  params.rays = 40;
  auto whole = client_->ComputeSdf("knight", params);
  const std::vector<double> g = Weights(mesh_.num_vertices());
  auto whole_vjp = client_->ComputeVjp("knight", params, g);
  ASSERT_TRUE(whole.ok() && whole_vjp.ok());
  std::vector<SampleRange> ranges = client::SplitSamples(mesh_.num_vertices(), 5);
  std::mt19937 rng(54);
  for (int round = 0; round < 3; ++round) {
    std::shuffle(ranges.begin(), ranges.end(), rng);
    std::vector<wire::SdfReply> parts;
    std::vector<wire::VjpReply> vjp_parts;
    for (const SampleRange& r : ranges) {
      SdfParams part = params;
      part.range = r;
      client::RemoteClient& c = *clients[rng() % 2];
      auto reply = c.ComputeSdf("knight", part);
      ASSERT_TRUE(reply.ok()) << reply.status();
      parts.push_back(std::move(*reply));
      auto vjp = c.ComputeVjp("knight", part,
                              absl::MakeConstSpan(g).subspan(
                                  r.begin, r.end - r.begin));
      ASSERT_TRUE(vjp.ok()) << vjp.status();
      vjp_parts.push_back(std::move(*vjp));
    }
    auto merged = client::MergeSdfReplies(mesh_, std::move(parts));
    ASSERT_TRUE(merged.ok()) << merged.status();
    ExpectSameReply(*merged, *whole);
    auto merged_vjp = client::MergeVjpReplies(mesh_.num_vertices(), vjp_parts);
    ASSERT_TRUE(merged_vjp.ok()) << merged_vjp.status();
    EXPECT_TRUE(SameBytes(merged_vjp->gradient, whole_vjp->gradient));
  }
}

TEST(FanOutMergeTest, RangesThatDoNotTileTheSamplesAreDataLoss) {
  Mesh mesh = *ReadMesh(testing::SharedMesh("decimated-knight.off"));
  wire::SdfReply part;
  part.result.resolved.params.range = {0, 10};
  part.result.values.assign(10, 1.0);
  EXPECT_EQ(client::MergeSdfReplies(mesh, {part}).status().code(),
            absl::StatusCode::kDataLoss);
}

TEST(FanOutMergeTest, RangesOfDifferentGenerationsAreAborted) {
  std::vector<wire::VjpReply> parts(2);
  for (int i = 0; i < 2; ++i) {
    parts[i].sums = ExactSums(3);
    parts[i].facts.generation = i;
  }
  EXPECT_EQ(client::MergeVjpReplies(1, parts).status().code(),
            absl::StatusCode::kAborted);
}

TEST(FanOutMergeTest, SplitSamplesTilesTheSamples) {
  EXPECT_EQ(client::SplitSamples(10, 3),
            (std::vector<SampleRange>{{0, 3}, {3, 6}, {6, 10}}));
  EXPECT_EQ(client::SplitSamples(2, 7).size(), 2u);
  EXPECT_TRUE(client::SplitSamples(0, 3).empty());
}

}  // namespace
}  // namespace meshgauge
