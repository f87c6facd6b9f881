// Thin regions, the area histogram, the colour map, the renderer and PNG
// files of `meshgauge report`, on shapes whose answer is known by
// construction.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>

#include "lib/core/colormap.h"
#include "lib/core/shapes.h"
#include "lib/core/thin_regions.h"
#include "lib/embree/render.h"
#include "lib/embree/sdf.h"
#include "lib/io/png_file.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::kNaN;

// The unit square [0,1]^2 (z = 0) as an n x n grid of triangle pairs.
Mesh Grid(int n) {
  Mesh m;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i)
      m.positions.push_back({1.0 * i / n, 1.0 * j / n, 0});
  }
  auto id = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      m.faces.push_back(
          Face::Triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1)));
      m.faces.push_back(
          Face::Triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1)));
    }
  }
  return m;
}

std::vector<double> ValuesOf(const Mesh& m, double (*f)(const Vec3&)) {
  std::vector<double> v;
  for (const Vec3& p : m.positions) v.push_back(f(p));
  return v;
}

TEST(TriangleAreaBelowTest, MatchesTheClosedFormInEveryVertexOrder) {
  // Values 0, 1, 2 over a triangle of area 8: below 0.5 a corner triangle of
  // area 8 * (0.5/1) * (0.5/2) = 1; below 1.5, 8 - 8 * (0.5/2) * (0.5/1) = 7.
  for (auto [a, b, c] : {std::tuple{0.0, 1.0, 2.0}, std::tuple{2.0, 0.0, 1.0},
                         std::tuple{1.0, 2.0, 0.0}}) {
    EXPECT_DOUBLE_EQ(TriangleAreaBelow(8, a, b, c, 0.5), 1);
    EXPECT_DOUBLE_EQ(TriangleAreaBelow(8, a, b, c, 1.0), 4);
    EXPECT_DOUBLE_EQ(TriangleAreaBelow(8, a, b, c, 1.5), 7);
    EXPECT_EQ(TriangleAreaBelow(8, a, b, c, 0), 0);
    EXPECT_EQ(TriangleAreaBelow(8, a, b, c, 2), 8);
  }
  EXPECT_EQ(TriangleAreaBelow(8, 1, 1, 1, 1), 0);  // strictly below.
  EXPECT_DOUBLE_EQ(TriangleAreaBelow(8, 0, 0, 2, 1), 6);
}

TEST(ThicknessAreaHistogramTest, EqualBinsOfALinearFieldHoldEqualArea) {
  const Mesh m = Grid(8);
  const auto x = ValuesOf(m, [](const Vec3& p) { return p.x; });
  auto h = ThicknessAreaHistogram(m, x, 0, 1, 10);
  ASSERT_TRUE(h.ok()) << h.status();
  for (double a : h->area) EXPECT_NEAR(a, 0.1, 1e-12);
  // Outside the range: clamped into the end bins.
  h = ThicknessAreaHistogram(m, x, 0.25, 0.75, 2);
  ASSERT_TRUE(h.ok());
  EXPECT_NEAR(h->area[0], 0.5, 1e-12);
  EXPECT_NEAR(h->area[1], 0.5, 1e-12);
}

TEST(ThicknessAreaHistogramTest, ValuesFarOutsideTheRangeFallInTheEndBins) {
  const Mesh m = Grid(4);
  std::vector<double> v(m.positions.size(), 1e30);  // x bins overflows int.
  v[0] = -1e30;
  auto h = ThicknessAreaHistogram(m, v, 0, 1e-9, 10);
  ASSERT_TRUE(h.ok());
  double sum = 0;
  for (double a : h->area) sum += a;
  EXPECT_NEAR(sum, 1, 1e-12);
  EXPECT_GT(h->area[9], 0.9);
}

TEST(ThicknessAreaHistogramTest, RejectsAnEmptyRangeAndBadBins) {
  const Mesh m = Grid(2);
  const std::vector<double> v(m.positions.size(), 1.0);
  EXPECT_EQ(ThicknessAreaHistogram(m, v, 1, 1, 4).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ThicknessAreaHistogram(m, v, 0, 1, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ThicknessAreaHistogram(m, {1.0}, 0, 1, 4).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(FindThinRegionsTest, ALinearFieldGivesOneStripOfExactAreaCentroidAndBox) {
  const Mesh m = Grid(10);
  const auto x = ValuesOf(m, [](const Vec3& p) { return p.x; });
  auto thin = FindThinRegions(m, x, {.t_min = 0.35});
  ASSERT_TRUE(thin.ok()) << thin.status();
  ASSERT_EQ(thin->regions.size(), 1u);
  const ThinRegion& r = thin->regions[0];
  EXPECT_NEAR(r.area, 0.35, 1e-12);
  EXPECT_NEAR(thin->thin_area, 0.35, 1e-12);
  EXPECT_NEAR(thin->total_area, 1, 1e-12);
  EXPECT_NEAR(r.centroid.x, 0.175, 1e-12);
  EXPECT_NEAR(r.centroid.y, 0.5, 1e-12);
  EXPECT_NEAR(r.box_max.x, 0.35, 1e-12);
  EXPECT_EQ(r.box_min, (Vec3{0, 0, 0}));
  EXPECT_EQ(r.box_max.y, 1);
  EXPECT_EQ(r.min_thickness, 0);
  EXPECT_EQ(r.min_vertex, 0);  // x = 0 on every row: the lowest id.
  EXPECT_EQ(thin->min_vertex, 0);
  EXPECT_EQ(r.faces, 2 * 4 * 10);  // columns 0..3 of cells.
  for (int32_t f = 0; f < m.num_faces(); ++f) {
    const double cx =
        (m.positions[m.faces[f].v[0]].x + m.positions[m.faces[f].v[1]].x +
         m.positions[m.faces[f].v[2]].x) /
        3;
    EXPECT_EQ(thin->face_region[f], cx < 0.4 ? 0 : -1) << f;
  }
}

TEST(FindThinRegionsTest, SeparateStripsAreSeparateRegionsLargestFirst) {
  const Mesh m = Grid(10);
  // Low at both ends, high in the middle.
  const auto v = ValuesOf(m, [](const Vec3& p) {
    return p.x < 0.5 ? 2 * p.x : 1 - 2.5 * (p.x - 0.6);
  });
  auto thin = FindThinRegions(m, v, {.t_min = 0.4, .min_region_area = 0.18});
  ASSERT_TRUE(thin.ok()) << thin.status();
  ASSERT_EQ(thin->regions.size(), 2u);
  // Left: 2x < 0.4 for x < 0.2; right: v < 0.4 for x > 0.84.
  EXPECT_NEAR(thin->regions[0].area, 0.2, 1e-12);
  EXPECT_NEAR(thin->regions[0].centroid.x, 0.1, 1e-12);
  EXPECT_NEAR(thin->regions[1].area, 0.16, 1e-12);
  EXPECT_NEAR(thin->regions[1].centroid.x, 0.92, 1e-12);
  EXPECT_NEAR(thin->regions[1].box_min.x, 0.84, 1e-12);
  EXPECT_NEAR(thin->thin_area, 0.36, 1e-12);
  EXPECT_FALSE(thin->regions[0].speck);
  EXPECT_TRUE(thin->regions[1].speck);  // smaller than min_region_area.
}

TEST(FindThinRegionsTest, FacesWithoutAValueAreMissingNeverThin) {
  const Mesh m = Grid(4);
  std::vector<double> v(m.positions.size(), 0.1);
  v[12] = kNaN;  // an inner vertex: six faces lose their value.
  auto thin = FindThinRegions(m, v, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  EXPECT_NEAR(thin->missing_area, 6 * 0.5 / 16, 1e-12);
  EXPECT_NEAR(thin->thin_area, 1 - 6 * 0.5 / 16, 1e-12);
  int missing_faces = 0;
  for (int32_t f = 0; f < m.num_faces(); ++f) {
    for (int k = 0; k < 3; ++k) {
      if (m.faces[f].v[k] == 12) {
        EXPECT_EQ(thin->face_region[f], -1);
        ++missing_faces;
      }
    }
  }
  EXPECT_EQ(missing_faces, 6);
  const std::vector<double> none(m.positions.size(), kNaN);
  thin = FindThinRegions(m, none, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  EXPECT_EQ(thin->min_vertex, -1);
  EXPECT_TRUE(thin->regions.empty());
}

TEST(FindThinRegionsTest,
     RejectsANonPositiveTMinANegativeSpeckAreaAndWrongSizes) {
  const Mesh m = Grid(2);
  const std::vector<double> v(m.positions.size(), 1.0);
  EXPECT_EQ(FindThinRegions(m, v, {.t_min = 0}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(FindThinRegions(m, v, {.t_min = kNaN}).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(FindThinRegions(m, v, {.t_min = 1, .min_region_area = -1})
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(FindThinRegions(m, {1.0, 2.0}, {.t_min = 1}).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(FindThinRegionsTest, QuadsAndCurvesUseTheirExactMeasure) {
  // A box of quads with values = z: below z = 0.5 of a 1 x 1 x 2 box are the
  // bottom (1) and a quarter of the four sides (4 * 2 * 0.25).
  const Mesh box = MakeBox(1, 1, 2, 0.25, /*quads=*/true);
  const auto z = ValuesOf(box, [](const Vec3& p) { return p.z; });
  auto thin = FindThinRegions(box, z, {.t_min = 0.5});
  ASSERT_TRUE(thin.ok());
  ASSERT_EQ(thin->regions.size(), 1u);
  EXPECT_NEAR(thin->regions[0].area, 1 + 4 * 2 * 0.25, 1e-12);
  EXPECT_NEAR(thin->total_area, 2 * 1 + 4 * 2, 1e-12);
  // A circle with values 1 + y: the lower half is one region (segments
  // joined at vertices), half the polygon's length.
  const Mesh circle = MakeCircle(1, 64);
  const auto y = ValuesOf(circle, [](const Vec3& p) { return 1 + p.y; });
  thin = FindThinRegions(circle, y, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  ASSERT_EQ(thin->regions.size(), 1u);
  EXPECT_NEAR(thin->regions[0].area, thin->total_area / 2, 1e-12);
  EXPECT_NEAR(thin->regions[0].centroid.x, 0, 1e-12);
  EXPECT_LT(thin->regions[0].centroid.y, -0.5);
}

TEST(ColorMapTest, LightnessRisesSteadilyAndMissingIsGrey) {
  double last = -1;
  for (int k = 0; k <= 64; ++k) {
    const double l = OkLightness(ThicknessColor(k / 64.0));
    EXPECT_GT(l, last) << k;
    if (k > 0) {
      EXPECT_NEAR(l - last, 0.63 / 64, 0.004) << k;  // uniform steps.
    }
    last = l;
  }
  EXPECT_EQ(ThicknessColor(kNaN), kNoValueGrey);
  EXPECT_EQ(ThicknessColor(-3), ThicknessColor(0));
  EXPECT_EQ(ThicknessColor(7), ThicknessColor(1));
  EXPECT_EQ((ColorScale{2, 4}(3)), ThicknessColor(0.5));
}

// A 10 x 10 x 2 plate and, 0.05 above it, a fin 0.2 thick, 6 long and 3
// high along y through the plate's middle.
Mesh PlateWithFin() {
  Mesh plate = MakeBox(10, 10, 2, 0.5);
  Mesh fin = MakeBox(0.2, 6, 3, 0.1);
  const int32_t offset = static_cast<int32_t>(plate.positions.size());
  for (Vec3 p : fin.positions) {
    plate.positions.push_back(p + Vec3{4.9, 2, 2.05});
  }
  for (Face f : fin.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] += offset;
    plate.faces.push_back(f);
  }
  return plate;
}

class PlateWithFinTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    mesh_ = new Mesh(PlateWithFin());
    SdfParams params;
    params.rays = 30;
    auto sdf = ComputeSdf(*mesh_, params);
    ASSERT_TRUE(sdf.ok()) << sdf.status();
    values_ = new std::vector<double>(sdf->values);
  }
  static bool InFin(const Vec3& p, double eps = 1e-9) {
    return p.x >= 4.9 - eps && p.x <= 5.1 + eps && p.y >= 2 - eps &&
           p.y <= 8 + eps && p.z >= 2.05 - eps && p.z <= 5.05 + eps;
  }
  static Mesh* mesh_;
  static std::vector<double>* values_;
};
Mesh* PlateWithFinTest::mesh_ = nullptr;
std::vector<double>* PlateWithFinTest::values_ = nullptr;

TEST_F(PlateWithFinTest, TheThinRegionIsTheFin) {
  auto thin = FindThinRegions(*mesh_, *values_, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  ASSERT_FALSE(thin->regions.empty());
  const ThinRegion& fin = thin->regions[0];
  EXPECT_TRUE(InFin(fin.box_min) && InFin(fin.box_max));
  EXPECT_TRUE(InFin(fin.centroid));
  EXPECT_NEAR(fin.centroid.x, 5, 0.01);
  EXPECT_NEAR(fin.centroid.y, 5, 0.02);
  EXPECT_LT(fin.min_thickness, 0.3);
  // Nearly all of the fin's surface (2 * (6*3 + 0.2*3 + 0.2*6)); nothing of
  // the plate.
  EXPECT_GT(fin.area, 0.9 * 39.6);
  EXPECT_LE(fin.area, 39.6 + 1e-9);
  for (size_t i = 1; i < thin->regions.size(); ++i) {
    EXPECT_TRUE(InFin(thin->regions[i].centroid)) << i;
  }
}

TEST_F(PlateWithFinTest, TheTopViewShowsTheThinColourOnTheFinOutlined) {
  auto thin = FindThinRegions(*mesh_, *values_, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  const ColorScale scale{0, 2.5};
  RenderOptions options;
  options.width = 200;
  options.height = 200;
  auto views = RenderViews(*mesh_, *values_, scale, thin->face_region,
                           StandardViews(2), options);
  ASSERT_TRUE(views.ok()) << views.status();
  ASSERT_EQ(views->size(), 4u);
  const RenderedView& top = (*views)[2];
  ASSERT_EQ(top.name, "top");
  // Top faces face the camera: Lambert 1, so the pixel is the map's colour.
  // The plate spans ~185 pixels, the fin rows 45..155: the fin (x in 4.9..5.1)
  // is the middle column, 3-4 pixels wide.
  const auto dist = [](Rgb a, Rgb b) {
    return std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
  };
  const Rgb thin_colour = scale(0.2), thick_colour = scale(2);
  int fin_pixels = 0, outline_pixels = 0;
  for (int y = 50; y < 150; ++y) {
    const Rgb centre = top.image.at(100, y);
    if (centre == kThinOutline) {
      ++outline_pixels;
    } else {
      EXPECT_LT(dist(centre, thin_colour), dist(centre, thick_colour)) << y;
      const int32_t f = top.face[y * 200 + 100];
      ASSERT_GE(f, 0);
      EXPECT_GE(thin->face_region[f], 0);
      ++fin_pixels;
    }
    for (int x : {20, 60, 140, 180}) {
      const Rgb plate = top.image.at(x, y);
      EXPECT_LT(dist(plate, thick_colour), dist(plate, thin_colour))
          << x << "," << y;
      EXPECT_NE(plate, kThinOutline);
    }
  }
  EXPECT_GT(fin_pixels, 0);
  // The fin's outline flanks it.
  int red_beside = 0;
  for (int x = 92; x <= 108; ++x)
    red_beside += top.image.at(x, 100) == kThinOutline;
  EXPECT_GE(red_beside, 2);
  // Background outside the plate.
  EXPECT_EQ(top.image.at(2, 2), (Rgb{255, 255, 255}));
  EXPECT_EQ(top.face[0], -1);
}

TEST(RenderViewsTest, FacesWithoutValuesAreGreyAndSizesAreChecked) {
  const Mesh box = MakeBox(1, 1, 1, 0.5);
  const std::vector<double> none(box.positions.size(), kNaN);
  RenderOptions options;
  options.width = options.height = 32;
  auto views =
      RenderViews(box, none, ColorScale{0, 1}, {}, StandardViews(2), options);
  ASSERT_TRUE(views.ok());
  const Rgb c = (*views)[2].image.at(16, 16);  // top face, Lambert 1.
  EXPECT_EQ(c, kNoValueGrey);
  options.width = 8;
  EXPECT_EQ(
      RenderViews(box, none, ColorScale{0, 1}, {}, StandardViews(2), options)
          .status()
          .code(),
      absl::StatusCode::kInvalidArgument);
  options.width = 32;
  EXPECT_EQ(
      RenderViews(box, {1.0}, ColorScale{0, 1}, {}, StandardViews(2), options)
          .status()
          .code(),
      absl::StatusCode::kInvalidArgument);
}

TEST(ColorMapTest, TheDefaultRangeIsCentredOnTMinWithAnOverflowColour) {
  // A 6 mm plate with t_min 2: 1, 2 and 6 mm must not look alike (the
  // values' range, 1..37, made them three shades of violet).
  const ColorScale scale = CenteredOnTMin(2);
  EXPECT_EQ(scale.lo, 0);
  EXPECT_EQ(scale.hi, 4);
  EXPECT_TRUE(scale.overflow);
  EXPECT_DOUBLE_EQ(scale.Position(2), 0.5);  // t_min in the middle.
  EXPECT_EQ(scale(4), ThicknessColor(1));
  EXPECT_EQ(scale(6), kOverflowColor);
  EXPECT_EQ(scale(37), kOverflowColor);
  EXPECT_EQ(scale(kNaN), kNoValueGrey);
  EXPECT_GT(OkLightness(scale(2)) - OkLightness(scale(1)), 0.15);
  // Without overflow the scale clamps, as before.
  EXPECT_EQ((ColorScale{0, 4}(37)), ThicknessColor(1));
  // The overflow colour is none of the map's, nor the outline or the grey.
  const auto dist = [](Rgb a, Rgb b) {
    return std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b);
  };
  for (int k = 0; k <= 256; ++k) {
    EXPECT_GT(dist(ThicknessColor(k / 256.0), kOverflowColor), 60) << k;
  }
  EXPECT_GT(dist(kNoValueGrey, kOverflowColor), 60);
  EXPECT_GT(dist(kThinOutline, kOverflowColor), 60);
  const std::vector<Rgb> colors = ColorsOf(scale, {1.0, 6.0, kNaN});
  EXPECT_EQ(colors, (std::vector<Rgb>{scale(1), kOverflowColor, kNoValueGrey}));
}

// A long strip [0, 8] x [0, 1] (z = 0) of two sliver triangles split along
// its diagonal, seen from the top 200 x 50: x = 1 is column ~30.6 (the
// strip spans columns 7..193 and rows 14..36).
Mesh Strip() {
  Mesh m;
  m.positions = {{0, 0, 0}, {8, 0, 0}, {8, 1, 0}, {0, 1, 0}};
  m.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 2, 3)};
  return m;
}

int ColumnOf(double x) {
  const double pixel = 8.0 / 200 * 1.08;
  return static_cast<int>(std::floor(100 + (x - 4) / pixel));
}

TEST(RenderViewsTest, TheOutlineFollowsTheIsoLineNotTheSliversEdges) {
  const Mesh strip = Strip();
  const auto x = ValuesOf(strip, [](const Vec3& p) { return p.x; });
  auto thin = FindThinRegions(strip, x, {.t_min = 1});
  ASSERT_TRUE(thin.ok());
  // Both slivers have a corner at x = 0: both are thin faces.
  EXPECT_EQ(thin->face_region, (std::vector<int32_t>{0, 0}));
  RenderOptions options;
  options.width = 200;
  options.height = 50;
  options.outline_below = 1;
  const ColorScale scale = CenteredOnTMin(1);
  auto views = RenderViews(strip, x, scale, thin->face_region,
                           {StandardViews(2)[2]}, options);
  ASSERT_TRUE(views.ok()) << views.status();
  const RenderedView& top = (*views)[0];
  const int iso = ColumnOf(1);
  for (int y = 17; y <= 33; ++y) {
    // A red line just right of x = 1 on every row, through both slivers.
    EXPECT_TRUE(top.image.at(iso + 1, y) == kThinOutline ||
                top.image.at(iso + 2, y) == kThinOutline)
        << y;
    // Left of it the thin part keeps its colours, interpolated per pixel.
    const int left = ColumnOf(0.5);
    EXPECT_NE(top.image.at(left, y), kThinOutline) << y;
    EXPECT_NEAR(top.value[y * 200 + left], 0.5, 0.05) << y;
    // Right of it no outline: not along the diagonal, not on the edges.
    for (int col = iso + 4; col < ColumnOf(7.9); ++col) {
      ASSERT_NE(top.image.at(col, y), kThinOutline) << col << "," << y;
      // The value follows x across the diagonal, and so does the colour.
      const double value = top.value[y * 200 + col];
      ASSERT_NEAR(value, 4 + (col + 0.5 - 100) * 8.0 / 200 * 1.08, 1e-6);
      ASSERT_EQ(top.image.at(col, y), scale(value));
    }
  }
  // Whole faces marked (no iso-line): the strip is all marked, the red is
  // outside it.
  options.outline_below = kNaN;
  views = RenderViews(strip, x, scale, thin->face_region,
                      {StandardViews(2)[2]}, options);
  ASSERT_TRUE(views.ok());
  EXPECT_NE((*views)[0].image.at(iso + 1, 25), kThinOutline);
}

TEST(RenderViewsTest, FaceValuesAreFlatAndOutlinedAlongTheFaceEdge) {
  const Mesh strip = Strip();
  const std::vector<double> faces = {0.5, 3};  // below, above t_min 1.
  RenderOptions options;
  options.width = 200;
  options.height = 50;
  options.samples = SampleSet::kFaces;
  options.outline_below = 1;
  const ColorScale scale = CenteredOnTMin(1);
  auto views = RenderViews(strip, faces, scale, {0, -1}, {StandardViews(2)[2]},
                           options);
  ASSERT_TRUE(views.ok()) << views.status();
  const RenderedView& top = (*views)[0];
  int red = 0;
  for (int y = 14; y < 37; ++y) {
    for (int col = 7; col < 193; ++col) {
      const size_t i = static_cast<size_t>(y) * 200 + col;
      const Rgb c = top.image.at(col, y);
      if (c == kThinOutline) {
        ++red;
        continue;
      }
      if (top.face[i] == 0) {
        EXPECT_EQ(c, scale(0.5)) << col << "," << y;
      }
      if (top.face[i] == 1) {
        EXPECT_EQ(c, kOverflowColor) << col << "," << y;
      }
    }
  }
  EXPECT_GT(red, 100);  // along the diagonal, on face 1's side.
  EXPECT_EQ(top.image.at(ColumnOf(2), 17), kOverflowColor);  // face 1.
  // Face values are checked against #F.
  EXPECT_EQ(RenderViews(strip, {1.0, 2.0, 3.0, 4.0}, scale, {},
                        {StandardViews(2)[2]}, options)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(PngFileTest, RoundTripsEveryPixel) {
  Image image(7, 5);
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 7; ++x) {
      image.at(x, y) = {static_cast<uint8_t>(x * 30),
                        static_cast<uint8_t>(y * 50),
                        static_cast<uint8_t>(x * y)};
    }
  }
  const std::string path =
      (std::filesystem::temp_directory_path() / "meshgauge_png_test.png")
          .string();
  ASSERT_TRUE(WritePng(path, image).ok());
  auto back = ReadPng(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->width, 7);
  EXPECT_EQ(back->height, 5);
  EXPECT_TRUE(back->pixels == image.pixels);
  std::ofstream(path) << "not a png";
  EXPECT_EQ(ReadPng(path).status().code(), absl::StatusCode::kInvalidArgument);
  std::filesystem::remove(path);
  EXPECT_EQ(ReadPng(path).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(WritePng("/nonexistent-dir/x.png", image).code(),
            absl::StatusCode::kInternal);
}

}  // namespace
}  // namespace meshgauge
