// SPEC §7: the penalty and its gradient, including the explicit derivative of
// the element measures, against central finite differences.
#include "lib/core/penalty.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "lib/core/integrals.h"
#include "lib/core/shapes.h"
#include "lib/core/thin_regions.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/fd_check.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using testing::RelativeError;
using testing::SharedMesh;

struct PenaltyFd {
  int64_t checked = 0, clean = 0, passed = 0;
  int64_t measure_term_matters = 0;  // FD disagrees with gradient - measure.
};

// For `columns` vertices and each coordinate, compares dP/dx with central
// differences of P wherever the whole hit table (primitives and kept sets) is
// unchanged at x +- step (lib/gradcheck).
PenaltyFd CheckPenalty(const Mesh& mesh, const PenaltyParams& pp, int columns,
                       const SdfParams& params = {}) {
  GradCheckOptions options;
  options.vertices = testing::SpreadVertices(mesh, columns, 5);
  options.penalty = pp;
  auto rep = RunGradCheck(mesh, params, options);
  EXPECT_TRUE(rep.ok()) << rep.status();
  PenaltyFd out;
  if (!rep.ok()) return out;
  for (const GradCheckRow& row : rep->penalty_rows) {
    ++out.checked;
    if (!row.clean) continue;
    ++out.clean;
    out.passed += row.relative_error <= 1e-5;
    out.measure_term_matters +=
        RelativeError(row.fd, row.analytic - row.measure_part) > 1e-3;
  }
  std::printf(
      "%s FD: checked %lld clean %lld passed %lld; without the measure "
      "terms %lld would fail\n",
      PenaltyFormName(pp.form), static_cast<long long>(out.checked),
      static_cast<long long>(out.clean), static_cast<long long>(out.passed),
      static_cast<long long>(out.measure_term_matters));
  return out;
}

void Expect(const PenaltyFd& rep) {
  EXPECT_GT(rep.checked, 0);
  EXPECT_GE(rep.clean, 0.9 * rep.checked);
  EXPECT_EQ(rep.passed, rep.clean);
  // The explicit measure derivative is not negligible: dropping it fails.
  EXPECT_GT(rep.measure_term_matters, rep.clean / 2);
}

// r(theta) = 1 + 0.05 sin(6 theta) with 120 segments.
Mesh NoisyCircle() {
  Mesh m = MakeCircle(1, 120);
  for (Vec3& p : m.positions)
    p *= 1 + 0.05 * std::sin(6 * std::atan2(p.y, p.x));
  return m;
}

TEST(PenaltyTest, OneSidedOnNoisyCircleMatchesFd) {
  Expect(CheckPenalty(
      NoisyCircle(), {.t_min = 2.5, .form = PenaltyForm::kOneSided, .power = 2},
      40));
}

TEST(PenaltyTest, ThesisFormOnHollowSquareMatchesFd) {
  Expect(CheckPenalty(MakeHollowSquare(4, 1, 0.2),
                      {.t_min = 1.5, .form = PenaltyForm::kThesis, .power = 2},
                      40));
}

TEST(PenaltyTest, OneSidedOnKnightMatchesFd) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  Expect(CheckPenalty(
      *mesh, {.t_min = 0.3, .form = PenaltyForm::kOneSided, .power = 3}, 25));
}

// Face samples (CAD parts): P = sum over faces of |f| phi(t_f), its
// gradient through each face's value and area.
TEST(PenaltyTest, FaceSampledPenaltyAndConstraintOnKnightMatchFd) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  SdfParams faces;
  faces.samples = SampleSet::kFaces;
  Expect(CheckPenalty(
      *mesh, {.t_min = 0.3, .form = PenaltyForm::kOneSided, .power = 3}, 25,
      faces));
  Expect(CheckPenalty(*mesh, {.t_min = 0.3, .form = PenaltyForm::kKs}, 25,
                      faces));
}

// On a plate of constant thickness h the face values are h, so the face
// penalty is the area times phi(h) exactly, and its thin regions join the
// faces below t_min.
TEST(PenaltyTest, FaceSampledPenaltyOfAPlateIsItsAreaTimesPhi) {
  const Mesh plate = MakeBox(4, 4, 0.5, 0.5);
  auto ev = SdfEvaluator::Create(plate);
  ASSERT_TRUE(ev.ok());
  SdfParams sp;
  sp.method = SdfMethod::kNormalRay;
  sp.samples = SampleSet::kFaces;
  auto r = (*ev)->Compute(sp);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(std::ssize(r->values), plate.num_faces());
  auto pen = ComputePenalty(**ev, *r, {.t_min = 1.0}, nullptr);
  ASSERT_TRUE(pen.ok()) << pen.status();
  EXPECT_EQ(std::ssize(pen->dp_dt), plate.num_faces());
  // Top and bottom (32 + 32 m^2) are 0.5 thick; the sides (4 x 4 x 0.5 =
  // 8 m^2) 4 across.
  EXPECT_NEAR(pen->value, 32 * std::pow(1 - 0.5 / 1.0, 2), 1e-9);
  auto thin = FindThinRegions(plate, r->values,
                              {.t_min = 1.0, .samples = SampleSet::kFaces});
  ASSERT_TRUE(thin.ok()) << thin.status();
  EXPECT_NEAR(thin->thin_area, 32, 1e-9);
  EXPECT_EQ(thin->regions.size(), 2u);  // top and bottom, not joined.
  EXPECT_GE(thin->min_face, 0);
  EXPECT_NEAR(thin->min_thickness, 0.5, 1e-9);
}

TEST(PenaltyTest, PenaltyAndConstraintOfConstantThicknessAreClosedForm) {
  // Every vertex of a fine circle has SDF = 2R D_est; one-sided phi is then
  // constant: P = 2 pi R (1 - 2R D_est / t_min)^2 up to the polygon's length.
  const Mesh circle = MakeCircle(0.5, 2048);
  auto ev = SdfEvaluator::Create(circle);
  SdfParams sp;
  sp.rays = 30;
  auto r = (*ev)->Compute(sp);
  const double d = testing::ClosedFormEstimate(2, 30, 30);
  auto pen = ComputePenalty(**ev, *r, {.t_min = 2.0}, nullptr);
  ASSERT_TRUE(pen.ok());
  EXPECT_NEAR(pen->value, M_PI * std::pow(1 - d / 2.0, 2), 1e-5);
  auto above = ComputePenalty(**ev, *r, {.t_min = 0.5}, nullptr);
  EXPECT_EQ(above->value, 0.0);
  // The KS constraint of a constant t is 1 - t/t_min whatever rho (the soft
  // max of a constant).
  for (double rho : {1.0, 50.0, 1e4}) {
    auto g = ComputePenalty(
        **ev, *r, {.t_min = 2.0, .form = PenaltyForm::kKs, .rho = rho},
        nullptr);
    ASSERT_TRUE(g.ok()) << g.status();
    EXPECT_NEAR(g->value, 1 - d / 2.0, 1e-5) << rho;
  }
}

TEST(PenaltyTest, KsConstraintOnNoisyCircleMatchesFd) {
  Expect(CheckPenalty(NoisyCircle(),
                      {.t_min = 2.5, .form = PenaltyForm::kKs, .rho = 20}, 40));
}

TEST(PenaltyTest, KsConstraintOnKnightMatchesFd) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  Expect(CheckPenalty(*mesh, {.t_min = 0.3, .form = PenaltyForm::kKs}, 25));
}

TEST(PenaltyTest, KsIsBelowTheMaximumAndTendsToIt) {
  // The area mean lies below max(1 - t/t_min) and rises to it with rho;
  // rho = 1e6 would overflow exp without the max shift.
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  auto ev = SdfEvaluator::Create(*mesh);
  auto r = (*ev)->Compute({});
  double t_low = 1e300;  // over the quadrature points, as G sees it.
  ForEachValuedElement(*mesh, r->values,
                       [&](const Element& e, const double* t) {
                         for (size_t q = 0; q < QuadratureRule(e.n).size(); ++q)
                           t_low = std::min(t_low, t[q]);
                       });
  const double max_s = 1 - t_low / 0.3;
  double last = -1e300;
  for (double rho : {10.0, 100.0, 1e3, 1e6}) {
    auto g = ComputePenalty(
        **ev, *r, {.t_min = 0.3, .form = PenaltyForm::kKs, .rho = rho},
        nullptr);
    ASSERT_TRUE(g.ok()) << g.status();
    ASSERT_TRUE(std::isfinite(g->value)) << rho;
    EXPECT_LE(g->value, max_s + 1e-12);
    EXPECT_GT(g->value, last);
    last = g->value;
  }
  EXPECT_NEAR(last, max_s, 1e-4);
}

TEST(PenaltyTest, RejectsPlanarMeshWithAllValuesMissing) {
  Mesh sheet;  // open: rays miss everywhere.
  sheet.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  sheet.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 2, 3)};
  auto ev = SdfEvaluator::Create(sheet);
  HitTable hits;
  auto r = (*ev)->Compute({}, {}, &hits);
  EXPECT_EQ(r->missing.vertices, 4);
  EXPECT_EQ(r->missing.area_fraction, 1.0);
  for (PenaltyForm form : {PenaltyForm::kOneSided, PenaltyForm::kKs}) {
    auto pen = ComputePenalty(**ev, *r, {.t_min = 1, .form = form}, &hits);
    EXPECT_EQ(pen.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_THAT(
        std::string(pen.status().message()),
        AllOf(HasSubstr("100.0% of the area"), HasSubstr("open or planar")));
  }
  // Raising the allowed fraction does not make an empty integral a number.
  auto all = ComputePenalty(**ev, *r, {.t_min = 1, .max_missing_fraction = 1},
                            nullptr);
  EXPECT_EQ(all.status().code(), absl::StatusCode::kFailedPrecondition);
}

TEST(PenaltyTest, RejectsInwardOrientedHorseNamingReorientation) {
  auto mesh = ReadMesh(SharedMesh("horse.ply"));
  ASSERT_TRUE(mesh.ok());
  ASSERT_LT(SignedVolume(*mesh), 0);  // the shared horse is inward oriented.
  auto ev = SdfEvaluator::Create(*mesh);
  auto r = (*ev)->Compute({});
  EXPECT_GT(r->missing.area_fraction, 0.5);
  auto pen = ComputePenalty(**ev, *r, {.t_min = 0.01}, nullptr);
  EXPECT_EQ(pen.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(pen.status().message()), HasSubstr("reorient"));
}

TEST(PenaltyTest, RejectsDoubleSidedMeshNamingIt) {
  // Every triangle of a box is doubled with the opposite orientation: all
  // normals cancel.
  Mesh box = MakeBox(1, 1, 1, 0.25, /*quads=*/false);
  const size_t nf = box.faces.size();
  for (size_t f = 0; f < nf; ++f) {
    const Face& t = box.faces[f];
    box.faces.push_back(Face::Triangle(t.v[0], t.v[2], t.v[1]));
  }
  auto ev = SdfEvaluator::Create(box);
  ASSERT_TRUE(ev.ok()) << ev.status();
  auto r = (*ev)->Compute({});
  auto pen = ComputePenalty(**ev, *r, {.t_min = 0.5}, nullptr);
  EXPECT_EQ(pen.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(pen.status().message()), HasSubstr("double-sided"));
}

TEST(PenaltyTest, CountsMissingValuesBelowTheAllowedFraction) {
  // A closed box with one open-ended region far out: most values exist.
  Mesh box = MakeBox(1, 1, 1, 0.25, /*quads=*/false);
  const int32_t base = static_cast<int32_t>(box.positions.size());
  for (const Vec3& p : {Vec3(5, 0, 0), Vec3(5.1, 0, 0), Vec3(5, 0.1, 0)}) {
    box.positions.push_back(p);
  }
  box.faces.push_back(Face::Triangle(base, base + 1, base + 2));
  auto ev = SdfEvaluator::Create(box);
  HitTable hits;
  auto r = (*ev)->Compute({}, {}, &hits);
  auto pen = ComputePenalty(**ev, *r, {.t_min = 2}, &hits);
  ASSERT_TRUE(pen.ok()) << pen.status();
  EXPECT_EQ(pen->missing.faces, 1);
  EXPECT_EQ(pen->missing.vertices, 3);
  EXPECT_GT(pen->missing.area_fraction, 0);
  EXPECT_LT(pen->missing.area_fraction, 0.01);
  // The same surface with a stricter allowance fails.
  EXPECT_EQ(
      ComputePenalty(**ev, *r, {.t_min = 2, .max_missing_fraction = 0}, nullptr)
          .status()
          .code(),
      absl::StatusCode::kFailedPrecondition);
}

TEST(PenaltyTest, RejectsBadParameters) {
  auto ev = SdfEvaluator::Create(MakeCircle(1, 16));
  auto r = (*ev)->Compute({});
  EXPECT_THAT(
      std::string(
          ComputePenalty(**ev, *r, {.t_min = 0}, nullptr).status().message()),
      HasSubstr("t_min must be a finite number > 0"));
  EXPECT_THAT(
      std::string(ComputePenalty(**ev, *r, {.t_min = 1, .power = 0.5}, nullptr)
                      .status()
                      .message()),
      HasSubstr("power n must be >= 1"));
  EXPECT_THAT(
      std::string(ComputePenalty(
                      **ev, *r,
                      {.t_min = 1, .form = PenaltyForm::kThesis, .power = 1.5},
                      nullptr)
                      .status()
                      .message()),
      HasSubstr("integer n"));
  EXPECT_THAT(
      std::string(ComputePenalty(
                      **ev, *r,
                      {.t_min = 1, .form = PenaltyForm::kKs, .rho = 0}, nullptr)
                      .status()
                      .message()),
      HasSubstr("rho must be"));
  EXPECT_THAT(std::string(ComputePenalty(
                              **ev, *r, {.t_min = 1, .max_missing_fraction = 2},
                              nullptr)
                              .status()
                              .message()),
              HasSubstr("missing fraction"));
  EXPECT_EQ(
      ComputePenalty(**ev, SdfResult{}, {.t_min = 1}, nullptr).status().code(),
      absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshgauge
