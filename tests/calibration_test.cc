// SPEC §8 calibration report.
#include "lib/embree/calibration.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

CalibrationParams Params(double t_min) {
  CalibrationParams p;
  p.t_min = t_min;
  return p;
}

TEST(CalibrationTest, TrayPlateThicknessAndAlphas) {
  auto mesh = ReadMesh(testing::SharedMesh("1002_tray_bottom.STL"));
  ASSERT_TRUE(mesh.ok());
  auto ev = SdfEvaluator::Create(*mesh);
  ASSERT_TRUE(ev.ok());
  const double t_min = 2.0;
  auto rep = Calibrate(**ev, Params(t_min));
  ASSERT_TRUE(rep.ok()) << rep.status();
  EXPECT_EQ(rep->compared, mesh->num_vertices());
  EXPECT_EQ(rep->lower + rep->equal + rep->higher, rep->compared);
  // Thickness 3.175 on (at least) the 316 vertices inside the big faces
  // (evaluator_test.cc), and no thickness below it.
  const std::vector<double>& t = rep->thickness;
  EXPECT_GE(std::count_if(t.begin(), t.end(),
                          [](double x) { return std::abs(x - 3.175) < 1e-5; }),
            316);
  EXPECT_GT(*std::min_element(t.begin(), t.end()), 3.175 - 1e-5);
  // alpha_1 and alpha_2 exactly as SPEC §8 defines them.
  double max_t = 0, min_s = 1e300;
  for (size_t i = 0; i < t.size(); ++i) {
    max_t = std::max(max_t, rep->thickness[i]);
    min_s = std::min(min_s, rep->sdf[i]);
  }
  EXPECT_DOUBLE_EQ(rep->alpha1, max_t / t_min);
  EXPECT_DOUBLE_EQ(rep->alpha2, min_s / t_min);
  // The cone's tilted rays are longer than the normal one on a flat plate.
  EXPECT_GT(rep->higher, rep->lower);
  int64_t total = 0;
  for (int64_t c : rep->sdf_histogram.counts) total += c;
  EXPECT_EQ(total, mesh->num_vertices());
  EXPECT_EQ(rep->sdf_histogram.counts.size(), 20u);
  // The third column: the inscribed ball is the plate's thickness inside
  // the big faces (but near their walls, min(T, 2d)), and never above the
  // normal ray's chord (the ball through its hit point has half its
  // length); counted over the same range.
  const std::vector<double>& b = rep->ball;
  EXPECT_GE(std::count_if(b.begin(), b.end(),
                          [](double x) { return std::abs(x - 3.175) < 1e-5; }),
            300);
  EXPECT_EQ(rep->ball_compared, mesh->num_vertices());
  EXPECT_EQ(rep->ball_lower + rep->ball_equal + rep->ball_higher,
            rep->ball_compared);
  EXPECT_GE(rep->ball_equal, 300);
  EXPECT_EQ(rep->ball_higher, 0);
  EXPECT_DOUBLE_EQ(rep->ball_alpha,
                   *std::min_element(b.begin(), b.end()) / t_min);
  total = 0;
  for (int64_t c : rep->ball_histogram.counts) total += c;
  EXPECT_EQ(total, mesh->num_vertices());
  EXPECT_EQ(rep->ball_histogram.lo, rep->sdf_histogram.lo);
}

TEST(CalibrationTest, CircleSdfEqualsThicknessWithinTolerance) {
  auto ev = SdfEvaluator::Create(MakeCircle(0.5, 256));
  // D_est = 0.99789 for 30 degrees and 30 rays: within 1% of the diameter.
  SdfParams sp;
  sp.rays = 30;
  auto rep = Calibrate(**ev, {.t_min = 1, .sdf = sp});
  ASSERT_TRUE(rep.ok());
  EXPECT_EQ(rep->equal, 256);
  auto strict =
      Calibrate(**ev, {.t_min = 1, .equal_tolerance = 1e-4, .sdf = sp});
  EXPECT_EQ(strict->lower, 256);
}

TEST(CalibrationTest, RejectsBadParameters) {
  auto ev = SdfEvaluator::Create(MakeCircle(0.5, 16));
  EXPECT_EQ(Calibrate(**ev, Params(-1)).status().code(),
            absl::StatusCode::kInvalidArgument);
  CalibrationParams no_bins = Params(1);
  no_bins.bins = 0;
  EXPECT_EQ(Calibrate(**ev, no_bins).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshgauge
