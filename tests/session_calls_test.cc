// SessionCalls without gRPC: on an in-memory store with a fake clock.
#include "server/session_calls.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "lib/core/mesh_repair.h"
#include "lib/core/shapes.h"
#include "lib/embree/sdf.h"
#include "server/make_session_store.h"
#include "tests/fake_clock.h"

namespace meshgauge {
namespace {

using server::CallControl;
using server::SessionTarget;
using ::testing::SizeIs;

class SessionCallsTest : public ::testing::Test {
 protected:
  void SetUp() override { MakeCalls(); }

  void MakeCalls() {
    calls_.reset();
    store_ = *server::MakeSessionStore(options_, &metrics_, &clock_);
    calls_ = std::make_unique<server::SessionCalls>(options_, store_.get(),
                                                    &metrics_);
    Create("ball", mesh_);
  }
  void Create(const std::string& id, const Mesh& mesh,
              const std::string& tenant = "") {
    auto repaired = RepairAndDiagnose(mesh, {});
    ASSERT_TRUE(repaired.ok()) << repaired.status();
    auto ticket =
        store_->Reserve(tenant, server::Session::EstimateBaseBytes(mesh));
    ASSERT_TRUE(ticket.ok()) << ticket.status();
    auto session =
        store_->Create(tenant, id, std::move(*repaired), std::move(*ticket));
    ASSERT_TRUE(session.ok()) << session.status();
  }
  SessionTarget Target(int rays = 16) const {
    SdfParams params;
    params.rays = rays;
    return {"ball", params, std::nullopt};
  }
  // Moves one vertex of the ball (a new generation).
  void Update() {
    auto session = store_->Get("", "ball");
    ASSERT_TRUE(session.ok());
    auto out = store_->UpdatePositions("", *session, 0, {0},
                                       {mesh_.positions[0] * 1.01}, {});
    ASSERT_TRUE(out.ok()) << out.status();
  }

  server::ServerOptions options_;
  server::Metrics metrics_;
  testing::FakeClock clock_;
  Mesh mesh_ = MakeIcosphere(1.0, 2);
  std::unique_ptr<server::SessionStore> store_;
  std::unique_ptr<server::SessionCalls> calls_;
};

TEST_F(SessionCallsTest, PrepareRefusesAnUnknownSession) {
  SessionTarget target = Target();
  target.session_id = "nope";
  EXPECT_EQ(calls_->Sdf("", target, false, {}).status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(SessionCallsTest, PrepareRefusesAnotherTenantsSession) {
  EXPECT_EQ(calls_->Sdf("tenant-b", Target(), false, {}).status().code(),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(calls_->GetMesh("tenant-b", "ball").status().code(),
            absl::StatusCode::kNotFound);
}

TEST_F(SessionCallsTest, PrepareRefusesAnotherGeneration) {
  SessionTarget target = Target();
  target.expected_generation = 1;
  EXPECT_EQ(calls_->Sdf("", target, false, {}).status().code(),
            absl::StatusCode::kAborted);
  target.expected_generation = 0;
  EXPECT_TRUE(calls_->Sdf("", target, false, {}).ok());
}

TEST_F(SessionCallsTest, AQueuedCallStopsWhenCancelled) {
  options_.max_concurrent_computations = 1;
  MakeCalls();
  // A call holds the only slot while it reports progress.
  std::atomic<bool> inside{false}, release{false};
  CallControl holder;
  holder.progress = [&](const server::CallProgress&) {
    inside = true;
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  };
  std::thread first([&] { (void)calls_->Sdf("", Target(), false, holder); });
  while (!inside) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  CallControl expired;
  expired.deadline = std::chrono::system_clock::now();
  EXPECT_EQ(calls_->Vjp("", Target(), {}, expired).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  CallControl cancelled;
  cancelled.cancelled = [] { return true; };
  EXPECT_EQ(calls_->Vjp("", Target(), {}, cancelled).status().code(),
            absl::StatusCode::kCancelled);
  release = true;
  first.join();
}

TEST_F(SessionCallsTest, ACancelledPassFailsAndIsNotCached) {
  CallControl cancelled;
  cancelled.cancelled = [] { return true; };
  EXPECT_EQ(calls_->Sdf("", Target(), false, cancelled).status().code(),
            absl::StatusCode::kCancelled);
  cancelled.deadline = std::chrono::system_clock::now();
  EXPECT_EQ(calls_->Sdf("", Target(), false, cancelled).status().code(),
            absl::StatusCode::kDeadlineExceeded);
  auto sdf = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(sdf.ok()) << sdf.status();
  EXPECT_FALSE(sdf->facts.reused_hits);
}

TEST_F(SessionCallsTest, ASecondCallReusesThePass) {
  auto first = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_FALSE(first->facts.reused_hits);
  auto second = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_TRUE(second->facts.reused_hits);
  EXPECT_EQ(second->pass, first->pass);
  auto vjp = calls_->Vjp("", Target(),
                         std::vector<double>(mesh_.num_vertices(), 1.0), {});
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  EXPECT_TRUE(vjp->reply.facts.reused_hits);
}

TEST_F(SessionCallsTest, AChangedParameterOrGenerationRecomputes) {
  ASSERT_TRUE(calls_->Sdf("", Target(16), false, {}).ok());
  auto other_rays = calls_->Sdf("", Target(24), false, {});
  ASSERT_TRUE(other_rays.ok()) << other_rays.status();
  EXPECT_FALSE(other_rays->facts.reused_hits);
  Update();
  auto moved = calls_->Sdf("", Target(24), false, {});
  ASSERT_TRUE(moved.ok()) << moved.status();
  EXPECT_FALSE(moved->facts.reused_hits);
  EXPECT_EQ(moved->facts.generation, 1);
}

TEST_F(SessionCallsTest, SdfIsTheLibrarysPassWithProgress) {
  std::vector<server::CallProgress> seen;
  CallControl control;
  control.progress = [&](const server::CallProgress& p) { seen.push_back(p); };
  auto sdf = calls_->Sdf("", Target(), true, control);
  ASSERT_TRUE(sdf.ok()) << sdf.status();
  auto expected = ComputeSdf(mesh_, Target().params);
  ASSERT_TRUE(expected.ok());
  EXPECT_EQ(sdf->pass->result.values, expected->values);
  ASSERT_TRUE(sdf->jacobian.has_value());
  EXPECT_THAT(sdf->jacobian->row_offsets, SizeIs(mesh_.num_vertices() + 1));
  EXPECT_NE(sdf->jacobian_claim, nullptr);
  EXPECT_GT(sdf->integral, 0);
  EXPECT_EQ(sdf->dimension, 3);
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.back().vertices_done, seen.back().vertices_total);
  EXPECT_EQ(seen.back().rays_total, mesh_.num_vertices() * 16);
}

TEST_F(SessionCallsTest, VjpChecksItsWeightsAndReply) {
  EXPECT_EQ(calls_->Vjp("", Target(), {1.0}, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
  auto vjp = calls_->Vjp("", Target(),
                         std::vector<double>(mesh_.num_vertices(), 1.0), {});
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  EXPECT_THAT(vjp->reply.gradient, SizeIs(mesh_.num_vertices()));
  EXPECT_EQ(vjp->dimension, 3);
  options_.max_message_bytes = 1000;
  MakeCalls();
  EXPECT_EQ(calls_
                ->Vjp("", Target(),
                      std::vector<double>(mesh_.num_vertices(), 1.0), {})
                .status()
                .code(),
            absl::StatusCode::kResourceExhausted);
}

TEST_F(SessionCallsTest, PenaltyWithGradientAndThinRegions) {
  PenaltyParams penalty;
  penalty.t_min = 5.0;  // the whole unit ball is thinner.
  wire::ThinRequest thin;
  thin.params.t_min = 5.0;
  auto out = calls_->Penalty("", Target(), penalty, thin, true, {});
  ASSERT_TRUE(out.ok()) << out.status();
  EXPECT_GT(out->reply.penalty.value, 0);
  EXPECT_THAT(out->reply.penalty.gradient, SizeIs(mesh_.num_vertices()));
  ASSERT_TRUE(out->thin.has_value());
  EXPECT_FALSE(out->thin->regions.empty());
  EXPECT_GT(out->reply.sdf_min, 0);
}

TEST_F(SessionCallsTest, CalibrateComparesPerVertex) {
  CalibrationParams params;
  params.t_min = 1.0;
  params.sdf = Target().params;
  auto report = calls_->Calibrate("", "ball", params, {});
  ASSERT_TRUE(report.ok()) << report.status();
  EXPECT_THAT(report->sdf, SizeIs(mesh_.num_vertices()));
  EXPECT_GT(report->compared, 0);
}

TEST_F(SessionCallsTest, GradCheckRunsOnACopyAndReportsProgress) {
  GradCheckOptions options;
  options.vertices = {0};
  int64_t rays_total = 0;
  CallControl control;
  control.progress = [&](const server::CallProgress& p) {
    rays_total = p.rays_total;
  };
  auto check = calls_->GradCheck("", Target(), options, control);
  ASSERT_TRUE(check.ok()) << check.status();
  EXPECT_FALSE(check->report.rows.empty());
  EXPECT_EQ(check->facts.generation, 0);
  EXPECT_EQ(rays_total, 7 * mesh_.num_vertices() * 16);  // base + 2 x 3.
  options.vertices = {static_cast<int32_t>(mesh_.num_vertices())};
  EXPECT_EQ(calls_->GradCheck("", Target(), options, {}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST_F(SessionCallsTest, GetMeshHoldsTheSessionsMesh) {
  auto view = calls_->GetMesh("", "ball");
  ASSERT_TRUE(view.ok()) << view.status();
  EXPECT_EQ(view->mesh().num_vertices(), mesh_.num_vertices());
  EXPECT_EQ(view->reader.generation(), 0);
  options_.max_message_bytes = 1000;
  MakeCalls();
  EXPECT_EQ(calls_->GetMesh("", "ball").status().code(),
            absl::StatusCode::kResourceExhausted);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// Sample ranges (ComputeSdf, ComputeVjp): refusals name the range and the
// mesh's count; a range's pass is cached apart from the whole one.
class SessionCallsRangeTest : public SessionCallsTest {
 protected:
  SessionTarget RangeTarget(int64_t begin, int64_t end) const {
    SessionTarget t = Target();
    t.params.range = {begin, end};
    return t;
  }
  int64_t vertices() const { return mesh_.num_vertices(); }
};

TEST_F(SessionCallsRangeTest, ARangeEndingPastTheMeshIsInvalid) {
  auto sdf = calls_->Sdf("", RangeTarget(0, vertices() + 1), false, {});
  EXPECT_EQ(sdf.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(sdf.status().message(),
              ::testing::HasSubstr(absl::StrCat("[0, ", vertices() + 1, ")")));
  EXPECT_THAT(sdf.status().message(),
              ::testing::HasSubstr(absl::StrCat(vertices(), " vertices")));
  auto vjp = calls_->Vjp("", RangeTarget(0, vertices() + 1),
                         std::vector<double>(vertices() + 1, 1.0), {});
  EXPECT_EQ(vjp.status().code(), absl::StatusCode::kInvalidArgument);
  auto penalty = calls_->Penalty("", RangeTarget(2, vertices() + 1),
                                 {.t_min = 0.1}, std::nullopt, true, {},
                                 std::vector<double>(vertices(), 1.0));
  EXPECT_EQ(penalty.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(penalty.status().message(),
              ::testing::HasSubstr(absl::StrCat("[2, ", vertices() + 1, ")")));
}

TEST_F(SessionCallsRangeTest, AnEmptyOrReversedRangeIsInvalid) {
  for (auto [begin, end] : {std::pair<int64_t, int64_t>{5, 5}, {9, 4}}) {
    EXPECT_EQ(calls_->Sdf("", RangeTarget(begin, end), false, {})
                  .status()
                  .code(),
              absl::StatusCode::kInvalidArgument);
  }
}

TEST_F(SessionCallsRangeTest, WeightsOfTheWholeMeshForARangeAreInvalid) {
  auto vjp = calls_->Vjp("", RangeTarget(2, 10),
                         std::vector<double>(vertices(), 1.0), {});
  EXPECT_EQ(vjp.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(vjp.status().message(), ::testing::HasSubstr("[2, 10)"));
}

TEST_F(SessionCallsRangeTest, ARangesPassIsCachedAndMatchesTheWhole) {
  auto whole = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(whole.ok());
  auto part = calls_->Sdf("", RangeTarget(10, 30), false, {});
  ASSERT_TRUE(part.ok()) << part.status();
  EXPECT_FALSE(part->facts.reused_hits);
  ASSERT_THAT(part->pass->result.values, SizeIs(20));
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(std::bit_cast<uint64_t>(part->pass->result.values[i]),
              std::bit_cast<uint64_t>(whole->pass->result.values[10 + i]));
  }
  auto again = calls_->Sdf("", RangeTarget(10, 30), false, {});
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->facts.reused_hits);
  // The session keeps one pass: the whole one is traced again, unchanged.
  auto whole_again = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(whole_again.ok());
  EXPECT_EQ(std::memcmp(whole_again->pass->result.values.data(),
                        whole->pass->result.values.data(),
                        8 * whole->pass->result.values.size()),
            0);
  // The range's reply carries its partial sums.
  auto vjp = calls_->Vjp("", RangeTarget(10, 30), std::vector<double>(20, 1.0),
                         {});
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  EXPECT_THAT(vjp->reply.sums, SizeIs(3 * vertices()));
}

TEST_F(SessionCallsRangeTest, APenaltyRangeWithoutTheValuesOrWithOthersIsInvalid) {
  const PenaltyParams penalty{.t_min = 0.1};
  auto whole = calls_->Sdf("", Target(), false, {});
  ASSERT_TRUE(whole.ok());
  std::vector<double> values = whole->pass->result.values;
  auto code = [&](const SessionTarget& target,
                  const std::vector<double>& v) {
    return calls_->Penalty("", target, penalty, std::nullopt, true, {}, v)
        .status();
  };
  EXPECT_EQ(code(RangeTarget(2, 10), {}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code(Target(), values).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code(RangeTarget(2, 10),
                 std::vector<double>(values.begin(), values.end() - 1))
                .code(),
            absl::StatusCode::kInvalidArgument);
  ASSERT_TRUE(code(RangeTarget(2, 10), values).ok());
  // A value of the range that is not the pass's, by one ulp.
  values[5] = std::nextafter(values[5], 1e300);
  const absl::Status changed = code(RangeTarget(2, 10), values);
  EXPECT_EQ(changed.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(changed.message(), ::testing::HasSubstr("values[5]"));
}

}  // namespace
}  // namespace meshgauge
