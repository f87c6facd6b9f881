// Accuracy against closed forms (SPEC §9) and the thesis' Tables 5.1/5.2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "lib/core/shapes.h"
#include "lib/embree/sdf.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

constexpr double kPi = std::numbers::pi;
using testing::ClosedFormEstimate;

SdfResult Compute(const Mesh& mesh, SdfParams params = {}) {
  auto result = ComputeSdf(mesh, params);
  EXPECT_TRUE(result.ok()) << result.status();
  return *result;
}

// Largest |SDF_p / (2R) - D_est| over all vertices.
double MaxRelativeError(const SdfResult& r, double diameter, double d_est) {
  double worst = 0;
  for (size_t i = 0; i < r.values.size(); ++i) {
    EXPECT_EQ(r.status[i], VertexStatus::kOk) << "vertex " << i;
    worst = std::max(worst, std::abs(r.values[i] / diameter - d_est) / d_est);
  }
  return worst;
}

TEST(AnalyticTest, CircleConvergesToClosedForm) {
  const double d_est = ClosedFormEstimate(2, 30, 30);
  SdfParams params;
  params.rays = 30;
  double previous = 1;
  for (int n : {32, 128, 512, 2048}) {
    const Mesh circle = MakeCircle(0.5, n);
    const SdfResult r = Compute(circle, params);
    const double err = MaxRelativeError(r, 1.0, d_est);
    const double integral = IntegrateNodal(circle, r.values).value;
    const double int_err = std::abs(integral / (2 * kPi * 0.5 * d_est) - 1);
    std::printf(
        "circle n=%5d  max |SDF/D_est-1| = %.3e  |int/(2 pi R D_est)-1| = "
        "%.3e\n",
        n, err, int_err);
    EXPECT_LT(err, previous) << "error must shrink with h";
    previous = err;
  }
  EXPECT_LT(previous, 1e-5);
}

TEST(AnalyticTest, SphereConvergesToClosedForm) {
  const double d_est = ClosedFormEstimate(3, 30, 100);
  double previous_mean = 1, previous_int = 1;
  for (int frequency : {4, 8, 16, 32}) {
    const Mesh sphere = MakeIcosphere(0.5, frequency);
    const SdfResult r = Compute(sphere);
    double mean_err = 0;
    for (double v : r.values) mean_err += std::abs(v - d_est) / d_est;
    mean_err /= static_cast<double>(r.values.size());
    const double integral = IntegrateNodal(sphere, r.values).value;
    const double int_err = std::abs(integral / (4 * kPi * 0.25 * d_est) - 1);
    std::printf(
        "sphere f=%3d V=%6zu  mean |SDF/D_est-1| = %.3e  |int/(4 pi R^2 "
        "D_est)-1| = %.3e\n",
        frequency, r.values.size(), mean_err, int_err);
    EXPECT_LT(mean_err, previous_mean);
    EXPECT_LT(int_err, previous_int);
    previous_mean = mean_err;
    previous_int = int_err;
  }
  EXPECT_LT(previous_mean, 2e-3);
  EXPECT_LT(previous_int, 1e-3);
}

// Thesis Table 5.1: circle R = 1, 30 degrees, 30 rays.
TEST(AnalyticTest, ThesisTable51Circle) {
  const double analytic = 4 * kPi;
  struct Row {
    double h, thesis_value, thesis_error_percent;
  };
  SdfParams params;
  params.rays = 30;
  std::printf("Table 5.1  h       thesis    err%%    meshgauge  err%%\n");
  for (const Row& row : {Row{0.05, 12.5211, 0.360}, Row{0.025, 12.5235, 0.341},
                         Row{0.0167, 12.5241, 0.336}}) {
    const Mesh circle =
        MakeCircle(1.0, static_cast<int>(std::ceil(2 * kPi / row.h)));
    const SdfResult r = Compute(circle, params);
    const double ours = IntegrateNodal(circle, r.values).value;
    const double err = std::abs(ours - analytic) / analytic * 100;
    std::printf("           %.4f  %.4f  %.3f   %.4f    %.3f\n", row.h,
                row.thesis_value, row.thesis_error_percent, ours, err);
    EXPECT_LE(err, row.thesis_error_percent);
  }
}

// Thesis Table 5.2: sphere R = 0.5, 30 degrees, 100 rays; our error against
// 4 pi R^2 D_est must be below 1% at h = 0.083.
TEST(AnalyticTest, ThesisTable52Sphere) {
  const double limit = 4 * kPi * 0.25 * ClosedFormEstimate(3, 30, 100);
  struct Row {
    double h, thesis_value, thesis_error_percent;
  };
  std::printf(
      "Table 5.2  h      thesis    err%%    meshgauge  err%% vs pi  err%% vs "
      "4piR^2 D_est\n");
  for (const Row& row : {Row{0.25, 3.02554, 3.694}, Row{0.125, 3.10882, 1.040},
                         Row{0.083, 3.12629, 0.487}}) {
    // Element size = mean edge length: the coarsest icosphere with mean
    // edge <= h.
    int f = 1;
    while (MeanEdgeLength(MakeIcosphere(0.5, f)) > row.h) ++f;
    const Mesh sphere = MakeIcosphere(0.5, f);
    const SdfResult r = Compute(sphere);
    const double ours = IntegrateNodal(sphere, r.values).value;
    const double err_pi = std::abs(ours - kPi) / kPi * 100;
    const double err_limit = std::abs(ours - limit) / limit * 100;
    std::printf(
        "           %.3f  %.5f  %.3f   %.5f   %.3f      %.3f     (f=%d, mean "
        "edge %.4f, V=%lld)\n",
        row.h, row.thesis_value, row.thesis_error_percent, ours, err_pi,
        err_limit, f, MeanEdgeLength(sphere),
        static_cast<long long>(sphere.num_vertices()));
    if (row.h < 0.1) {
      EXPECT_LT(err_limit, 1.0);
    }
  }
}

TEST(AnalyticTest, NormalRayOnSlabIsItsThickness) {
  const Mesh slab = MakeBox(10, 10, 1, 0.5);
  SdfParams params;
  params.method = SdfMethod::kNormalRay;
  const SdfResult r = Compute(slab, params);
  int checked = 0;
  for (int64_t i = 0; i < slab.num_vertices(); ++i) {
    const Vec3& p = slab.positions[i];
    const bool interior = p.x > 0 && p.x < 10 && p.y > 0 && p.y < 10;
    if (!interior || (p.z != 0 && p.z != 1)) continue;
    ASSERT_EQ(r.status[i], VertexStatus::kOk);
    EXPECT_NEAR(r.values[i], 1.0, 1e-12) << "vertex " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 2 * 19 * 19);
}

TEST(AnalyticTest, HollowSquareNormalRayMatchesGeometry) {
  const double side = 4, r = 1;
  const Mesh mesh = MakeHollowSquare(side, r, 0.05);
  SdfParams params;
  params.method = SdfMethod::kNormalRay;
  const SdfResult res = Compute(mesh, params);
  // Hole polygon: n vertices at angles -2 pi i / n (n odd).
  int n = 0;
  for (int32_t region : mesh.face_regions) n += region == 1;
  int mid_sides = 0, hole_vertices = 0;
  for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
    const Vec3& p = mesh.positions[i];
    ASSERT_EQ(res.status[i], VertexStatus::kOk) << i;
    if (std::hypot(p.x, p.y) < 1.5) {
      // OUTWARD: across the hole to the segment opposite: r (1 + cos(pi/n)).
      EXPECT_NEAR(res.values[i], r * (1 + std::cos(kPi / n)), 1e-12);
      ++hole_vertices;
    } else if ((p.x == 0 || p.y == 0) &&
               std::abs(std::hypot(p.x, p.y) - side / 2) < 1e-12) {
      // INWARD from a mid-side: to the hole polygon along the axis. The
      // polygon crosses the axis between its vertices at distance
      // r cos(pi/n) / cos(angle to the nearest segment midpoint).
      const double phi = std::atan2(-p.y, -p.x);   // direction to centre.
      const double to_hit = std::atan2(p.y, p.x);  // polar angle of the hit.
      const double seg = 2 * kPi / n;
      const double mid = (std::floor(to_hit / seg) + 0.5) * seg;
      const double hit_radius = r * std::cos(kPi / n) / std::cos(to_hit - mid);
      EXPECT_NEAR(res.values[i], side / 2 - hit_radius, 1e-12) << phi;
      ++mid_sides;
    }
  }
  EXPECT_EQ(mid_sides, 4);
  EXPECT_EQ(hole_vertices, n);
  // And the analytic continuum distance side/2 - r within the polygon's sag.
  EXPECT_LT(r * (1 - std::cos(kPi / n)), 1e-3);
}

}  // namespace
}  // namespace meshgauge
