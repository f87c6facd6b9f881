// The wire conversion layer (proto/wire/convert.h): library values survive
// the round trip bit for bit, and a malformed reply is DATA_LOSS, never a
// short or shifted result.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "meshgauge/v1/service_config.h"
#include "proto/wire/convert.h"
#include "proto/wire/gradcheck_convert.h"
#include "proto/wire/reply_convert.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using testing::SameBits;

SdfResult SmallResult() {
  SdfResult r;
  r.values = {0.1, std::nan(""), 0.30000000000000004, 1e-300};
  r.normalized = {0, std::nan(""), 0.5, 1};
  r.status = {VertexStatus::kOk, VertexStatus::kNoHit, VertexStatus::kOk,
              VertexStatus::kOk};
  r.hits = {10, 0, 9, 8};
  r.kept = {7, 0, 6, 5};
  r.rays_traced = 40;
  r.world_frame_vertices = 1;
  r.missing = {.vertices = 1, .faces = 2, .area_fraction = 0.125};
  r.resolved.rays = 10;
  r.trace_seconds = 0.5;
  return r;
}

// The stream of `r` in chunks of `step` vertices, then its summary.
absl::StatusOr<wire::SdfReply> RoundTrip(const SdfResult& r, int64_t step,
                                         const SdfParams& params) {
  wire::SdfReply reply;
  const int64_t n = std::ssize(r.values);
  for (int64_t b = 0; b < n; b += step) {
    v1::SdfChunk c;
    wire::ToWireChunk(r, nullptr, 3, b, std::min(n, b + step), &c);
    if (absl::Status s = wire::AppendChunk(c, &reply); !s.ok()) return s;
  }
  v1::SdfSummary s;
  wire::ToWireSummary(r, 2.5, {7, false, 0.25}, &s);
  if (absl::Status st = wire::FinishReply(s, params, &reply); !st.ok()) {
    return st;
  }
  return reply;
}

TEST(WireTest, SdfStreamRoundTripsBitForBit) {
  const SdfResult r = SmallResult();
  SdfParams params;
  params.rays = 10;
  auto reply = RoundTrip(r, 3, params);
  ASSERT_TRUE(reply.ok()) << reply.status();
  EXPECT_TRUE(SameBits(reply->result.values, r.values));
  EXPECT_TRUE(SameBits(reply->result.normalized, r.normalized));
  EXPECT_EQ(reply->result.status, r.status);
  EXPECT_EQ(reply->result.hits, r.hits);
  EXPECT_EQ(reply->result.kept, r.kept);
  EXPECT_EQ(reply->result.rays_traced, 40);
  EXPECT_EQ(reply->result.world_frame_vertices, 1);
  EXPECT_EQ(reply->result.missing.area_fraction, 0.125);
  EXPECT_EQ(reply->result.resolved.rays, 10);
  EXPECT_EQ(reply->result.trace_seconds, 0.5);
  EXPECT_EQ(reply->integral, 2.5);
  EXPECT_EQ(reply->facts.generation, 7);
}

TEST(WireTest, ChunkThatDoesNotContinueTheStreamIsDataLoss) {
  const SdfResult r = SmallResult();
  wire::SdfReply reply;
  v1::SdfChunk c;
  wire::ToWireChunk(r, nullptr, 3, 1, 3, &c);  // vertices 0 never came.
  const absl::Status s = wire::AppendChunk(c, &reply);
  EXPECT_EQ(s.code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(std::string(s.message()), HasSubstr("does not continue"));
  v1::SdfChunk shorter;
  wire::ToWireChunk(r, nullptr, 3, 0, 2, &shorter);
  shorter.mutable_hits()->RemoveLast();
  EXPECT_EQ(wire::AppendChunk(shorter, &reply).code(),
            absl::StatusCode::kDataLoss);
}

TEST(WireTest, UnknownVertexStatusIsDataLoss) {
  const SdfResult r = SmallResult();
  wire::SdfReply reply;
  v1::SdfChunk c;
  wire::ToWireChunk(r, nullptr, 3, 0, 4, &c);
  c.set_status(2, static_cast<v1::VertexStatus>(42));
  EXPECT_EQ(wire::AppendChunk(c, &reply).code(), absl::StatusCode::kDataLoss);
}

TEST(WireTest, SummaryCountingOtherVerticesIsDataLoss) {
  const SdfResult r = SmallResult();
  wire::SdfReply reply;
  v1::SdfChunk c;
  wire::ToWireChunk(r, nullptr, 3, 0, 3, &c);  // the last vertex is missing.
  ASSERT_TRUE(wire::AppendChunk(c, &reply).ok());
  v1::SdfSummary s;
  wire::ToWireSummary(r, 0, {}, &s);
  EXPECT_EQ(wire::FinishReply(s, {}, &reply).code(),
            absl::StatusCode::kDataLoss);
}

// Opposite points round trip bit for bit when asked for; a stream without
// them (an older server) or with them unasked is DATA_LOSS.
TEST(WireTest, OppositePointsRoundTripAndMissingOnesAreDataLoss) {
  SdfResult r = SmallResult();
  r.opposite = {Vec3(0.1 + 1e-12, 2, 3), Vec3(NAN, NAN, NAN), Vec3(4, 5, 6),
                Vec3(-1, -2, -3e-300)};
  SdfParams asked;
  asked.opposite_points = true;
  auto back = RoundTrip(r, 3, asked);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->result.opposite.size(), 4u);
  EXPECT_EQ(back->result.opposite[0], r.opposite[0]);
  EXPECT_TRUE(std::isnan(back->result.opposite[1].x));
  EXPECT_EQ(back->result.opposite[3], r.opposite[3]);
  EXPECT_EQ(RoundTrip(r, 3, {}).status().code(), absl::StatusCode::kDataLoss);
  r.opposite.clear();
  EXPECT_EQ(RoundTrip(r, 3, asked).status().code(),
            absl::StatusCode::kDataLoss);
}

// Face samples (SPEC v2 §5c): the sample set round-trips (unset meaning
// vertices), an unknown one is refused, and a reply whose summary holds
// another sample set than the one asked for (an older server ignores
// SdfParameters.samples and sends vertices) is DATA_LOSS.
TEST(WireTest, SampleSetRoundTripsAndAReplyOfOtherSamplesIsDataLoss) {
  SdfParams faces;
  faces.samples = SampleSet::kFaces;
  auto back = wire::FromWire(wire::ToWire(faces), 4096);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->samples, SampleSet::kFaces);
  v1::SdfParameters unset;
  EXPECT_EQ(wire::FromWire(unset, 4096)->samples, SampleSet::kVertices);
  unset.set_samples(static_cast<v1::SampleSet>(7));
  EXPECT_EQ(wire::FromWire(unset, 4096).status().code(),
            absl::StatusCode::kInvalidArgument);

  SdfResult r = SmallResult();
  r.resolved.params.samples = SampleSet::kFaces;
  EXPECT_TRUE(RoundTrip(r, 3, faces).ok());
  const absl::Status vertices_sent =
      RoundTrip(SmallResult(), 3, faces).status();
  EXPECT_EQ(vertices_sent.code(), absl::StatusCode::kDataLoss);
  EXPECT_THAT(std::string(vertices_sent.message()), HasSubstr("older"));
  EXPECT_EQ(RoundTrip(r, 3, {}).status().code(), absl::StatusCode::kDataLoss);
  // A server older than the field leaves the summary's set unset: fine for
  // vertices, DATA_LOSS for faces.
  wire::SdfReply reply;
  v1::SdfChunk c;
  wire::ToWireChunk(SmallResult(), nullptr, 3, 0, 4, &c);
  ASSERT_TRUE(wire::AppendChunk(c, &reply).ok());
  v1::SdfSummary old;
  wire::ToWireSummary(SmallResult(), 0, {}, &old);
  old.clear_samples();
  wire::SdfReply copy = reply;
  EXPECT_TRUE(wire::FinishReply(old, {}, &reply).ok());
  EXPECT_EQ(wire::FinishReply(old, faces, &copy).code(),
            absl::StatusCode::kDataLoss);
}

TEST(WireTest, JacobianRowsRoundTripAndMismatchedRowsAreDataLoss) {
  const SdfResult r = SmallResult();
  SparseJacobian j;
  j.row_offsets = {0, 2, 2, 3, 4};
  j.columns = {0, 3, 2, 1};
  j.values = {Vec3(1, 2, 3), Vec3(-0.1, 0.2, 1e-310), Vec3(4, 5, 6),
              Vec3(0, 0, -1)};
  wire::SdfReply reply;
  reply.jacobian.emplace();
  for (int64_t b : {0, 2}) {
    v1::SdfChunk c;
    wire::ToWireChunk(r, &j, 3, b, b + 2, &c);
    ASSERT_TRUE(wire::AppendChunk(c, &reply).ok());
  }
  EXPECT_EQ(reply.jacobian->row_offsets, j.row_offsets);
  EXPECT_EQ(reply.jacobian->columns, j.columns);
  EXPECT_EQ(reply.jacobian->values, j.values);
  wire::SdfReply bad;
  bad.jacobian.emplace();
  v1::SdfChunk c;
  wire::ToWireChunk(r, &j, 3, 0, 2, &c);
  c.mutable_derivatives()->RemoveLast();
  EXPECT_EQ(wire::AppendChunk(c, &bad).code(), absl::StatusCode::kDataLoss);
}

TEST(WireTest, ParametersRoundTrip) {
  SdfParams p;
  p.method = SdfMethod::kNormalRay;
  p.cone_angle_degrees = 47.5;
  p.rays = 33;
  p.kappa = 0;  // an explicit 0 is not the default 1.
  p.min_weight_angle = 0.01;
  p.max_distance = 3.25;
  p.self_hit_epsilon = 1e-7;
  p.normal_weighting = NormalWeighting::kAngle;
  auto back = wire::FromWire(wire::ToWire(p), 4096);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->method == p.method && back->rays == 33 &&
              back->cone_angle_degrees == 47.5 && back->kappa == 0 &&
              back->min_weight_angle == 0.01 && back->max_distance == 3.25 &&
              back->self_hit_epsilon == 1e-7 &&
              back->normal_weighting == NormalWeighting::kAngle);
  // Over the server's limit: refused for the cone, ignored by the methods
  // that trace no more than one ray.
  EXPECT_TRUE(wire::FromWire(wire::ToWire(p), 32).ok());
  SdfParams cone = p;
  cone.method = SdfMethod::kCone;
  EXPECT_EQ(wire::FromWire(wire::ToWire(cone), 32).status().code(),
            absl::StatusCode::kInvalidArgument);
  SdfParams sphere;
  sphere.method = SdfMethod::kSphere;
  sphere.contact_angle_degrees = 37.5;
  sphere.opposite_points = true;
  auto sphere_back = wire::FromWire(wire::ToWire(sphere), 4096);
  ASSERT_TRUE(sphere_back.ok()) << sphere_back.status();
  EXPECT_TRUE(*sphere_back == sphere);
  v1::SdfParameters defaults;
  defaults.set_method(v1::SDF_METHOD_SPHERE);
  auto defaulted = wire::FromWire(defaults, 4096);
  ASSERT_TRUE(defaulted.ok());
  EXPECT_EQ(defaulted->contact_angle_degrees, 60);  // 0 on the wire.
  defaults.set_contact_angle_degrees(90);
  EXPECT_EQ(wire::FromWire(defaults, 4096).status().code(),
            absl::StatusCode::kInvalidArgument);

  const PenaltyParams pp{.t_min = 0.3,
                         .form = PenaltyForm::kKs,
                         .power = 3,
                         .rho = 20,
                         .max_missing_fraction = 0};
  v1::ComputePenaltyRequest req;
  wire::ToWire(pp, &req);
  auto pb = wire::PenaltyFromWire(req);
  ASSERT_TRUE(pb.ok()) << pb.status();
  EXPECT_TRUE(pb->t_min == 0.3 && pb->form == PenaltyForm::kKs &&
              pb->power == 3 && pb->rho == 20 && pb->max_missing_fraction == 0);
}

TEST(WireTest, SessionInfoAndCalibrationReportRoundTrip) {
  wire::SessionInfo s{.session_id = "a-b",
                      .dimension = 2,
                      .num_vertices = 5,
                      .num_faces = 4,
                      .generation = 9,
                      .memory_bytes = 1234,
                      .bvh_builds = 2,
                      .bvh_refits = 7,
                      .idle_seconds = 1.5,
                      .signed_volume = -0.25,
                      .closed = true,
                      .warnings = {"one", "two"}};
  v1::SessionInfo w;
  wire::ToWire(s, &w);
  const wire::SessionInfo back = wire::FromWire(w);
  EXPECT_EQ(back.session_id, s.session_id);
  EXPECT_EQ(back.dimension, 2);
  EXPECT_EQ(back.generation, 9);
  EXPECT_EQ(back.memory_bytes, 1234);
  EXPECT_EQ(back.bvh_refits, 7);
  EXPECT_EQ(back.idle_seconds, 1.5);
  EXPECT_EQ(back.signed_volume, -0.25);
  EXPECT_TRUE(back.closed);
  EXPECT_EQ(back.warnings, s.warnings);

  CalibrationReport rep;
  rep.compared = 10;
  rep.lower = 3;
  rep.equal = 4;
  rep.higher = 3;
  rep.alpha1 = 1.25;
  rep.alpha2 = 0.5;
  rep.sdf_histogram = {0.1, 0.9, {1, 2, 3}};
  rep.thickness_histogram = {0.1, 0.9, {3, 2, 1}};
  rep.ball_compared = 9;
  rep.ball_lower = 5;
  rep.ball_equal = 3;
  rep.ball_higher = 1;
  rep.ball_alpha = 0.25 + 1e-12;  // float32 would change it.
  rep.ball_histogram = {0.1, 0.9, {2, 2, 5}};
  v1::CalibrateResponse cr;
  wire::ToWire(rep, &cr);
  const CalibrationReport rb = wire::FromWire(cr);
  EXPECT_EQ(rb.compared, 10);
  EXPECT_EQ(rb.equal, 4);
  EXPECT_EQ(rb.alpha1, 1.25);
  EXPECT_EQ(rb.sdf_histogram.counts, rep.sdf_histogram.counts);
  EXPECT_EQ(rb.thickness_histogram.counts, rep.thickness_histogram.counts);
  EXPECT_EQ(rb.thickness_histogram.hi, 0.9);
  EXPECT_TRUE(rb.ball_compared == 9 && rb.ball_lower == 5 &&
              rb.ball_equal == 3 && rb.ball_higher == 1 &&
              rb.ball_alpha == rep.ball_alpha);
  EXPECT_EQ(rb.ball_histogram.counts, rep.ball_histogram.counts);
  EXPECT_EQ(rb.ball_histogram.lo, 0.1);
}

TEST(WireTest, ThinSurfaceRoundTripsBitForBitAndOnlyTheLargestAreSent) {
  ThinSurface t;
  t.t_min = 0.1;
  t.total_area = 1.0 + 1e-12;  // float32 would change these.
  t.thin_area = 0.1 + 1e-13;
  t.missing_area = 1e-20;
  t.min_thickness = 0.01 + 1e-15;
  t.min_vertex = 7;
  t.min_point = {0.1, 0.2 + 1e-16, -0.3};
  for (int i = 0; i < 3; ++i) {
    ThinRegion r;
    r.faces = 10 - i;
    r.area = 0.05 / (i + 1) + 1e-14;
    r.min_thickness = 0.02 + i * 1e-13;
    r.min_vertex = 100 + i;
    r.min_point = {1.0 / 3, 1.0 * i, 2};
    r.centroid = {0.1 + 1e-12, 0, -1.0 * i};
    r.box_min = {-1, -2, -3};
    r.box_max = {1, 2, 3 + 1e-15};
    r.speck = i == 2;
    t.regions.push_back(r);
  }
  v1::ThinSurface w;
  wire::ToWire(t, 2, &w);
  EXPECT_EQ(w.region_count(), 3);
  auto back = wire::FromWire(w, 0.1);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->total_area, t.total_area);
  EXPECT_EQ(back->thin_area, t.thin_area);
  EXPECT_EQ(back->missing_area, t.missing_area);
  EXPECT_EQ(back->min_thickness, t.min_thickness);
  EXPECT_EQ(back->min_vertex, 7);
  EXPECT_EQ(back->min_point, t.min_point);
  ASSERT_EQ(back->regions.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const ThinRegion &a = back->regions[i], &b = t.regions[i];
    EXPECT_EQ(a.faces, b.faces);
    EXPECT_EQ(a.area, b.area);
    EXPECT_EQ(a.min_thickness, b.min_thickness);
    EXPECT_EQ(a.min_vertex, b.min_vertex);
    EXPECT_EQ(a.min_point, b.min_point);
    EXPECT_EQ(a.centroid, b.centroid);
    EXPECT_EQ(a.box_min, b.box_min);
    EXPECT_EQ(a.box_max, b.box_max);
    EXPECT_EQ(a.speck, b.speck);
  }
  w.mutable_regions(1)->mutable_centroid()->RemoveLast();
  EXPECT_EQ(wire::FromWire(w, 0.1).status().code(),
            absl::StatusCode::kDataLoss);
}

TEST(WireTest, ThinRequestRejectsANegativeSpeckAreaAndTooManyRegions) {
  v1::ComputePenaltyRequest r;
  r.set_t_min(1);
  auto none = wire::ThinFromWire(r);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  r.set_with_thin_regions(true);
  auto defaults = wire::ThinFromWire(r);
  ASSERT_TRUE(defaults.ok() && defaults->has_value());
  EXPECT_EQ((*defaults)->max_regions, 1000);
  EXPECT_EQ((*defaults)->params.t_min, 1);
  r.set_min_region_area(-1);
  EXPECT_EQ(wire::ThinFromWire(r).status().code(),
            absl::StatusCode::kInvalidArgument);
  r.set_min_region_area(std::numeric_limits<double>::infinity());
  EXPECT_EQ(wire::ThinFromWire(r).status().code(),
            absl::StatusCode::kInvalidArgument);
  r.set_min_region_area(0);
  r.set_max_thin_regions(100001);
  EXPECT_EQ(wire::ThinFromWire(r).status().code(),
            absl::StatusCode::kInvalidArgument);
  r.set_max_thin_regions(-1);
  EXPECT_EQ(wire::ThinFromWire(r).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

// The C++ client compiles in the one service config file the Python client
// ships: the same bytes.
// Options and report of GradCheck: every field back as sent, doubles bit
// for bit (values float32 would change); a verdict its counts contradict
// and a coordinate out of range are DATA_LOSS.
TEST(WireTest, GradCheckOptionsAndReportRoundTrip) {
  GradCheckOptions o;
  o.samples = 7;
  o.seed = 0;  // a seed of 0 is sent, not replaced by the default.
  o.vertices = {3, 1};
  o.relative_step = 1.0000000000000002e-7;
  o.tolerance = 3e-6;
  o.min_clean_fraction = 0.75;
  o.penalty =
      PenaltyParams{.t_min = 0.1 + 1e-12, .form = PenaltyForm::kKs, .rho = 30};
  v1::GradCheckRequest req;
  wire::ToWire(o, &req);
  auto back = wire::GradCheckFromWire(req);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->samples, 7);
  EXPECT_EQ(back->seed, 0u);
  EXPECT_EQ(back->vertices, o.vertices);
  EXPECT_EQ(back->relative_step, o.relative_step);
  EXPECT_EQ(back->tolerance, o.tolerance);
  EXPECT_EQ(back->min_clean_fraction, 0.75);
  ASSERT_TRUE(back->penalty.has_value());
  EXPECT_EQ(back->penalty->t_min, o.penalty->t_min);
  EXPECT_EQ(back->penalty->form, PenaltyForm::kKs);
  EXPECT_EQ(back->penalty->rho, 30);
  // Unset fields take the library's defaults.
  auto defaults = wire::GradCheckFromWire(v1::GradCheckRequest());
  ASSERT_TRUE(defaults.ok());
  const GradCheckOptions library;
  EXPECT_EQ(defaults->samples, library.samples);
  EXPECT_EQ(defaults->seed, library.seed);
  EXPECT_EQ(defaults->relative_step, library.relative_step);
  EXPECT_EQ(defaults->tolerance, library.tolerance);
  EXPECT_EQ(defaults->min_clean_fraction, library.min_clean_fraction);
  EXPECT_FALSE(defaults->penalty.has_value());

  GradCheckReport rep;
  rep.rows.push_back({.row = 4,
                      .vertex = 9,
                      .coordinate = 2,
                      .analytic = 0.1 + 1e-15,
                      .fd = 0.1 + 2e-15,
                      .relative_error = 1e-14,
                      .clean = true,
                      .step = 1.0000000000000002e-8});
  rep.penalty_rows.push_back({.row = -1,
                              .vertex = 9,
                              .coordinate = 1,
                              .analytic = 1.0 / 3,
                              .fd = 1.0 / 3,
                              .clean = true,
                              .measure_part = 1e-300});
  rep.vjp_rows.push_back({.row = -1,
                          .vertex = 4,
                          .coordinate = 0,
                          .analytic = 0.0073 + 1e-17,
                          .fd = 0.0073 - 1e-17,
                          .relative_error = 2e-15,
                          .clean = true,
                          .step = 1e-9});
  rep.vjp_checks = rep.vjp_passed = 1;
  rep.clean = rep.passed = 1;
  rep.penalty_clean = rep.penalty_passed = 1;
  rep.rays_traced = 123456789012;
  rep.retried = 2;
  v1::GradCheckReport w;
  wire::ToWire(rep, 5, &w);
  EXPECT_EQ(w.generation(), 5);
  EXPECT_EQ(w.verdict(), v1::GRAD_CHECK_VERDICT_PASS);
  auto got = wire::FromWire(w);
  ASSERT_TRUE(got.ok()) << got.status();
  ASSERT_EQ(got->rows.size(), 1u);
  EXPECT_EQ(got->rows[0].analytic, rep.rows[0].analytic);
  EXPECT_EQ(got->rows[0].fd, rep.rows[0].fd);
  EXPECT_EQ(got->rows[0].step, rep.rows[0].step);
  EXPECT_EQ(got->rows[0].coordinate, 2);
  ASSERT_EQ(got->penalty_rows.size(), 1u);
  EXPECT_EQ(got->penalty_rows[0].analytic, 1.0 / 3);
  EXPECT_EQ(got->penalty_rows[0].measure_part, 1e-300);
  ASSERT_EQ(got->vjp_rows.size(), 1u);
  EXPECT_EQ(got->vjp_rows[0].analytic, rep.vjp_rows[0].analytic);
  EXPECT_EQ(got->vjp_rows[0].fd, rep.vjp_rows[0].fd);
  EXPECT_EQ(got->vjp_rows[0].vertex, 4);
  EXPECT_EQ(got->rays_traced, rep.rays_traced);
  EXPECT_EQ(got->retried, 2);
  EXPECT_EQ(got->Verdict(), GradCheckVerdict::kPass);

  v1::GradCheckReport lying = w;
  lying.set_passed(0);  // a clean entry out of tolerance: FAIL, not PASS.
  EXPECT_EQ(wire::FromWire(lying).status().code(), absl::StatusCode::kDataLoss);
  v1::GradCheckReport bad_axis = w;
  bad_axis.mutable_rows(0)->set_coordinate(3);
  EXPECT_EQ(wire::FromWire(bad_axis).status().code(),
            absl::StatusCode::kDataLoss);
}

// The unary replies back as sent (doubles bit for bit, 2D gradients as
// dimension-2 vectors); a reply a client cannot read is DATA_LOSS.
TEST(WireTest, UnaryRepliesRoundTripAndMalformedOnesAreDataLoss) {
  v1::UpdatePositionsResponse up;
  wire::ToWire(wire::UpdateResult{7, true, 0.1 + 1e-17}, &up);
  const wire::UpdateResult u = wire::FromWire(up);
  EXPECT_EQ(u.generation, 7);
  EXPECT_TRUE(u.refit);
  EXPECT_EQ(u.bvh_seconds, 0.1 + 1e-17);

  const std::vector<Vec3> g = {Vec3(1.0 / 3, -2e-300, 0), Vec3(5, 6, 0)};
  for (int dim : {2, 3}) {
    v1::ComputeVjpResponse vjp;
    wire::ToWire(wire::VjpReply{g, {4, true, 1.5}, {}}, dim, &vjp);
    EXPECT_EQ(vjp.gradient_size(), 2 * dim);
    auto back = wire::FromWire(vjp);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->gradient, g);
    EXPECT_EQ(back->facts.generation, 4);
    EXPECT_TRUE(back->facts.reused_hits);
  }
  v1::ComputeVjpResponse bad;
  wire::ToWire(wire::VjpReply{g, {}, {}}, 3, &bad);
  bad.set_dimension(4);
  EXPECT_EQ(wire::FromWire(bad).status().code(), absl::StatusCode::kDataLoss);
  bad.set_dimension(3);
  bad.mutable_gradient()->RemoveLast();
  EXPECT_EQ(wire::FromWire(bad).status().code(), absl::StatusCode::kDataLoss);

  wire::PenaltyReply pen;
  pen.penalty.value = 0.1 + 1e-16;
  pen.penalty.missing = {3, 2, 0.25};
  pen.penalty.gradient = g;
  pen.sdf_min = 1.0 / 7;
  pen.world_frame_vertices = 9;
  pen.facts = {11, false, 2.5};
  for (bool with_gradient : {true, false}) {
    v1::ComputePenaltyResponse w;
    wire::ToWire(pen, 3, with_gradient, &w);
    EXPECT_EQ(w.skipped_faces(), 2);
    auto back = wire::FromWire(w, with_gradient);
    ASSERT_TRUE(back.ok()) << back.status();
    EXPECT_EQ(back->penalty.value, pen.penalty.value);
    EXPECT_EQ(back->penalty.missing.vertices, 3);
    EXPECT_EQ(back->penalty.missing.area_fraction, 0.25);
    EXPECT_EQ(back->penalty.gradient, with_gradient ? g : std::vector<Vec3>{});
    EXPECT_EQ(back->sdf_min, pen.sdf_min);
    EXPECT_EQ(back->world_frame_vertices, 9);
    EXPECT_EQ(back->facts.generation, 11);
  }

  EXPECT_EQ(*wire::ServingFromHealthBytes(std::string("\x08\x01", 2)), true);
  EXPECT_EQ(*wire::ServingFromHealthBytes(std::string("\x08\x02", 2)), false);
  for (const std::string& junk :
       {std::string(), std::string("\x08", 1), std::string("\x08\x03", 2),
        std::string("\x10\x01", 2), std::string("\x08\x01\x00", 3)}) {
    EXPECT_EQ(wire::ServingFromHealthBytes(junk).status().code(),
              absl::StatusCode::kDataLoss);
  }
}

TEST(ServiceConfigTest, TheCompiledConfigIsTheFileNextToTheProto) {
  std::ifstream in(MESHGAUGE_SOURCE_DIR "/proto/meshgauge/v1/service_config.json");
  std::stringstream file;
  file << in.rdbuf();
  ASSERT_FALSE(file.str().empty());
  EXPECT_EQ(std::string(v1::kServiceConfigJson), file.str());
  EXPECT_NE(file.str().find("\"retryPolicy\""), std::string::npos);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

TEST(WireRangeTest, AnEmptyOrNegativeRangeIsInvalid) {
  for (auto [begin, end] :
       {std::pair<int64_t, int64_t>{3, 3}, {5, 2}, {-1, 4}}) {
    v1::SampleRange r;
    r.set_begin(begin);
    r.set_end(end);
    EXPECT_EQ(wire::FromWire(r).status().code(),
              absl::StatusCode::kInvalidArgument);
  }
  v1::SampleRange ok;
  ok.set_begin(0);
  ok.set_end(7);
  EXPECT_EQ(*wire::FromWire(ok), (SampleRange{0, 7}));
}

TEST(WireRangeTest, VjpPartialSumsTravelExactly) {
  ExactSums sums(6);
  sums.Add(0, 1.0);
  sums.Add(0, 0x1p-70);
  sums.Add(0, 0x1p-140);
  sums.Add(4, -3.5);
  sums.Add(5, 1e300);  // z: not sent in 2D
  for (int dim : {2, 3}) {
    wire::VjpReply reply{RoundVectors(sums), {1, false, 0}, sums};
    v1::ComputeVjpResponse msg;
    wire::ToWire(reply, dim, &msg);
    EXPECT_EQ(msg.tail_counts_size(), 2 * dim);
    EXPECT_EQ(msg.tail_counts(0), 2);
    auto back = wire::FromWire(msg);
    ASSERT_TRUE(back.ok()) << back.status();
    ASSERT_EQ(back->sums.size(), 6);
    for (int j = 0; j < 2; ++j) {
      for (int c = 0; c < dim; ++c) {
        EXPECT_EQ(back->sums.Terms(3 * j + c), sums.Terms(3 * j + c));
      }
    }
    msg.add_tails(1.0);  // one more tail than the counts say
    EXPECT_EQ(wire::FromWire(msg).status().code(), absl::StatusCode::kDataLoss);
  }
}

TEST(WireRangeTest, ASummaryOfAnotherRangeIsDataLoss) {
  wire::SdfReply reply;
  v1::SdfSummary s;  // no range: an older server's whole pass
  SdfParams params;
  params.range = {4, 9};
  EXPECT_EQ(wire::FinishReply(s, params, &reply).code(),
            absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace meshgauge
