// SPEC v2 §5c: face samples. Every method at the faces' centroids along
// their own normals: closed forms on a slab of triangles and of quads, the
// derivatives against finite differences (SPEC §6), the same values for any
// thread count, and what face samples refuse.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_values.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
#include "lib/embree/calibration.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/fd_check.h"
#include "tests/test_util.h"
#include "tests/thread_count_check.h"

namespace meshgauge {
namespace {

using testing::CheckJacobian;
using testing::ExpectFdAgreement;
using testing::ExpectSameForOneAndTwoThreads;
using testing::SharedMesh;

SdfParams Faces(SdfMethod method) {
  SdfParams p;
  p.method = method;
  p.samples = SampleSet::kFaces;
  p.opposite_points = true;
  return p;
}

// A slab of thickness 1, its faces triangles or quads: at every face of the
// top farther than 1 from the side walls, the normal ray and the inscribed
// ball give 1 and the point straight below; the cone's rays, up to 15 deg
// off the axis, give between 1 and 1 / cos 15 deg.
void ExpectSlabFacesMeasureTheThickness(bool quads) {
  const double side = 6, thickness = 1;
  const Mesh slab = MakeBox(side, side, thickness, 0.25, quads);
  auto ev = SdfEvaluator::Create(slab);
  ASSERT_TRUE(ev.ok()) << ev.status();
  for (SdfMethod method :
       {SdfMethod::kNormalRay, SdfMethod::kSphere, SdfMethod::kCone}) {
    auto r = (*ev)->Compute(Faces(method));
    ASSERT_TRUE(r.ok()) << r.status();
    ASSERT_EQ(std::ssize(r->values), slab.num_faces());
    ASSERT_EQ(std::ssize(r->opposite), slab.num_faces());
    int interior = 0;
    for (int64_t f = 0; f < slab.num_faces(); ++f) {
      const Face& face = slab.faces[f];
      bool top = true;
      for (int k = 0; k < face.size; ++k) {
        top &= slab.positions[face.v[k]].z == thickness;
      }
      const Vec3 c = FaceCentroid(slab, f);
      if (!top || std::min({c.x, c.y, side - c.x, side - c.y}) < thickness) {
        continue;
      }
      ++interior;
      ASSERT_EQ(r->status[f], VertexStatus::kOk) << "face " << f;
      if (method == SdfMethod::kCone) {
        EXPECT_GE(r->values[f], thickness * (1 - 1e-12)) << "face " << f;
        EXPECT_LE(r->values[f], thickness / std::cos(std::numbers::pi / 12));
        EXPECT_NEAR(r->opposite[f].z, 0, 1e-12);
        continue;
      }
      EXPECT_NEAR(r->values[f], thickness, 1e-12) << "face " << f;
      EXPECT_NEAR(r->opposite[f].x, c.x, 1e-12);
      EXPECT_NEAR(r->opposite[f].y, c.y, 1e-12);
      EXPECT_NEAR(r->opposite[f].z, 0, 1e-12);
    }
    EXPECT_GT(interior, quads ? 60 : 120);
    EXPECT_EQ(r->missing.faces, 0);
  }
}

TEST(FaceSamplesTest, SlabOfTrianglesMeasuresTheThicknessAtEveryFace) {
  ExpectSlabFacesMeasureTheThickness(/*quads=*/false);
}

// A quad face: both of its triangles are its own and ignored (the centroid
// of these square cells lies on their shared diagonal), and its axis is
// their summed normal.
TEST(FaceSamplesTest, SlabOfQuadsMeasuresTheThicknessAtEveryFace) {
  ExpectSlabFacesMeasureTheThickness(/*quads=*/true);
}

// Values, statuses, opposite points and the hit table do not depend on the
// thread count.
TEST(FaceSamplesTest, SameForAnyThreadCount) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  auto ev = SdfEvaluator::Create(*mesh);
  ASSERT_TRUE(ev.ok());
  for (SdfMethod method : {SdfMethod::kCone, SdfMethod::kSphere}) {
    const SdfResult r = ExpectSameForOneAndTwoThreads(**ev, Faces(method));
    EXPECT_GT(r.CountStatus(VertexStatus::kOk), 0.95 * mesh->num_faces());
  }
}

// SPEC §6 through the centroid's weights and the face normal, for the three
// methods, on triangles, quads and 2D segments (an OUTWARD region).
TEST(FaceSamplesTest, DerivativesMatchFiniteDifferences) {
  auto knight = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(knight.ok());
  SdfParams cone = Faces(SdfMethod::kCone);
  cone.rays = 24;
  ExpectFdAgreement(CheckJacobian(*knight, cone, 12, "knight faces cone"));
  ExpectFdAgreement(CheckJacobian(*knight, Faces(SdfMethod::kNormalRay), 12,
                                  "knight faces normal"));
  ExpectFdAgreement(CheckJacobian(*knight, Faces(SdfMethod::kSphere), 12,
                                  "knight faces sphere"));
  Mesh quads = MakeVoxelSolid(
      {4, 3, 1}, {0.5, 0.5, 0.4},
      [](int i, int j, int) { return !(i == 1 && j == 1); }, /*quads=*/true);
  for (size_t i = 0; i < quads.positions.size(); ++i) {
    quads.positions[i] *= 1 + 0.01 * std::sin(12.9898 * i);
  }
  ExpectFdAgreement(CheckJacobian(quads, cone, 20, "quad plate faces cone"));
  ExpectFdAgreement(CheckJacobian(quads, Faces(SdfMethod::kSphere), 20,
                                  "quad plate faces sphere"));
  ExpectFdAgreement(CheckJacobian(MakeHollowSquare(4, 1, 0.2),
                                  Faces(SdfMethod::kCone), 40,
                                  "2D plate with hole faces cone"));
}

// A face without a value is skipped by the integral and counted, with its
// area, as missing; the others count with their own value over their area.
TEST(FaceSamplesTest, IntegralAndMissingValuesWeighFacesByTheirArea) {
  Mesh square;
  square.positions = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(2, 1, 0),
                      Vec3(0, 1, 0)};
  square.faces = {Face::Triangle(0, 1, 2), Face::Triangle(0, 2, 3),
                  Face::Quad(0, 1, 2, 3)};
  const std::vector<double> values = {3, std::nan(""), 0.5};
  const IntegralResult integral = IntegrateFaceValues(square, values);
  EXPECT_EQ(integral.value, 3 * 1 + 0.5 * 2);
  EXPECT_EQ(integral.measure, 3);
  EXPECT_EQ(integral.skipped_faces, 1);
  const MissingValues missing = CountMissingFaces(square, values);
  EXPECT_EQ(missing.faces, 1);
  EXPECT_EQ(missing.vertices, 0);
  EXPECT_EQ(missing.area_fraction, 0.25);
}

// The calibration compares vertex values; VJP weights are one per face; the
// penalty integrates the face values (penalty_test.cc checks it).
TEST(FaceSamplesTest, CalibrationAndVertexSizedWeightsAreRefused) {
  const Mesh box = MakeBox(2, 1, 0.5, 0.25);
  auto ev = SdfEvaluator::Create(box);
  ASSERT_TRUE(ev.ok());
  HitTable hits;
  auto r = (*ev)->Compute(Faces(SdfMethod::kCone), {}, &hits);
  ASSERT_TRUE(r.ok());
  PenaltyParams pen;
  pen.t_min = 1;
  auto p = ComputePenalty(**ev, *r, pen, &hits);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(std::ssize(p->dp_dt), box.num_faces());
  EXPECT_EQ(std::ssize(p->gradient), box.num_vertices());
  CalibrationParams cal;
  cal.t_min = 1;
  cal.sdf.samples = SampleSet::kFaces;
  EXPECT_EQ(Calibrate(**ev, cal).status().code(),
            absl::StatusCode::kInvalidArgument);
  const std::vector<double> per_vertex(box.num_vertices(), 1.0);
  auto wrong = ComputeVjp(**ev, hits, per_vertex);
  EXPECT_EQ(wrong.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(wrong.status().message().find("one value per face"),
            std::string::npos)
      << wrong.status();
  const std::vector<double> per_face(box.num_faces(), 1.0);
  auto vjp = ComputeVjp(**ev, hits, per_face);
  ASSERT_TRUE(vjp.ok()) << vjp.status();
  EXPECT_EQ(std::ssize(*vjp), box.num_vertices());
}

}  // namespace
}  // namespace meshgauge
