// SPEC §7: the penalty and its gradient, including the explicit derivative of
// the element measures, against central finite differences.
#include "lib/penalty.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "lib/mesh_io.h"
#include "lib/shapes.h"
#include "tests/fd_check.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using testing::RelativeError;
using testing::SharedMesh;

struct PenaltyFd {
  int64_t checked = 0, clean = 0, passed = 0;
  int64_t measure_term_matters = 0;  // FD disagrees with gradient - measure.
};

// For `columns` vertices and each coordinate, compares dP/dx with central
// differences of P wherever the whole hit table (primitives and kept sets) is
// unchanged at x +- step.
PenaltyFd CheckPenalty(const Mesh& mesh, const PenaltyParams& pp, int columns) {
  PenaltyFd rep;
  auto ev = SdfEvaluator::Create(mesh);
  EXPECT_TRUE(ev.ok());
  HitTable base_hits;
  auto base = (*ev)->Compute({}, {}, &base_hits);
  auto pen = ComputePenalty(**ev, base->values, pp, &base_hits);
  EXPECT_TRUE(pen.ok()) << pen.status();
  const double step = 1e-7 * BoundingBoxDiagonal(mesh);
  for (int col = 0; col < columns; ++col) {
    const int32_t j =
        static_cast<int32_t>((col * 7919LL + 5) % mesh.num_vertices());
    for (int c = 0; c < mesh.dimension; ++c) {
      double p_at[2];
      bool clean = true;
      for (int s = 0; s < 2; ++s) {
        Vec3 x = mesh.positions[j];
        x[c] += (s == 0 ? 1 : -1) * step;
        EXPECT_TRUE(
            (*ev)
                ->UpdatePositions(std::vector<int32_t>{j}, std::vector<Vec3>{x})
                .ok());
        HitTable hits;
        auto r = (*ev)->Compute({}, {}, &hits);
        clean &= hits.primitives == base_hits.primitives &&
                 hits.kept == base_hits.kept;
        p_at[s] = ComputePenalty(**ev, r->values, pp, nullptr)->value;
      }
      EXPECT_TRUE((*ev)
                      ->UpdatePositions(std::vector<int32_t>{j},
                                        std::vector<Vec3>{mesh.positions[j]})
                      .ok());
      const double fd = (p_at[0] - p_at[1]) / (2 * step);
      const double an = pen->gradient[j][c];
      if (fd == 0 && an == 0) continue;
      ++rep.checked;
      if (!clean) continue;
      ++rep.clean;
      rep.passed += RelativeError(fd, an) <= 1e-5;
      const double without = an - pen->measure_gradient[j][c];
      rep.measure_term_matters += RelativeError(fd, without) > 1e-3;
    }
  }
  std::printf(
      "penalty FD: checked %lld clean %lld passed %lld; without the measure "
      "term %lld would fail\n",
      static_cast<long long>(rep.checked), static_cast<long long>(rep.clean),
      static_cast<long long>(rep.passed),
      static_cast<long long>(rep.measure_term_matters));
  return rep;
}

void Expect(const PenaltyFd& rep) {
  EXPECT_GT(rep.checked, 0);
  EXPECT_GE(rep.clean, 0.9 * rep.checked);
  EXPECT_EQ(rep.passed, rep.clean);
  // The explicit measure derivative is not negligible: dropping it fails.
  EXPECT_GT(rep.measure_term_matters, rep.clean / 2);
}

TEST(PenaltyTest, OneSidedOnNoisyCircleMatchesFd) {
  Mesh m = MakeCircle(1, 120);
  for (Vec3& p : m.positions)
    p *= 1 + 0.05 * std::sin(6 * std::atan2(p.y, p.x));
  Expect(CheckPenalty(
      m, {.t_min = 2.5, .form = PenaltyForm::kOneSided, .power = 2}, 40));
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

TEST(PenaltyTest, ValueOfConstantThicknessIsClosedForm) {
  // Every vertex of a fine circle has SDF = 2R D_est; one-sided phi is then
  // constant: P = 2 pi R (1 - 2R D_est / t_min)^2 up to the polygon's length.
  const Mesh circle = MakeCircle(0.5, 2048);
  auto ev = SdfEvaluator::Create(circle);
  SdfParams sp;
  sp.rays = 30;
  auto r = (*ev)->Compute(sp);
  const double d = testing::ClosedFormEstimate(2, 30, 30);
  auto pen = ComputePenalty(**ev, r->values, {.t_min = 2.0}, nullptr);
  ASSERT_TRUE(pen.ok());
  EXPECT_NEAR(pen->value, M_PI * std::pow(1 - d / 2.0, 2), 1e-5);
  auto above = ComputePenalty(**ev, r->values, {.t_min = 0.5}, nullptr);
  EXPECT_EQ(above->value, 0.0);
}

TEST(PenaltyTest, SkipsFacesWithoutValuesAndCountsThem) {
  Mesh sheet;  // open: rays miss everywhere.
  sheet.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  sheet.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 2, 3)};
  auto ev = SdfEvaluator::Create(sheet);
  HitTable hits;
  auto r = (*ev)->Compute({}, {}, &hits);
  auto pen = ComputePenalty(**ev, r->values, {.t_min = 1}, &hits);
  ASSERT_TRUE(pen.ok());
  EXPECT_EQ(pen->skipped_faces, 2);
  EXPECT_EQ(pen->value, 0);
}

TEST(PenaltyTest, RejectsBadParameters) {
  auto ev = SdfEvaluator::Create(MakeCircle(1, 16));
  auto r = (*ev)->Compute({});
  EXPECT_THAT(std::string(ComputePenalty(**ev, r->values, {.t_min = 0}, nullptr)
                              .status()
                              .message()),
              HasSubstr("t_min must be a finite number > 0"));
  EXPECT_THAT(std::string(ComputePenalty(**ev, r->values,
                                         {.t_min = 1, .power = 0.5}, nullptr)
                              .status()
                              .message()),
              HasSubstr("power n must be >= 1"));
  EXPECT_THAT(
      std::string(ComputePenalty(
                      **ev, r->values,
                      {.t_min = 1, .form = PenaltyForm::kThesis, .power = 1.5},
                      nullptr)
                      .status()
                      .message()),
      HasSubstr("integer n"));
  EXPECT_EQ(ComputePenalty(**ev, std::vector<double>(3), {.t_min = 1}, nullptr)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshgauge
