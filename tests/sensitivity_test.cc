// SPEC §6: every derivative against central finite differences.
#include "lib/core/sensitivity.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

#include "lib/core/shapes.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/fd_check.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Jitter;
using testing::CheckJacobian;
using testing::ExpectFdAgreement;
using testing::SharedMesh;

SdfParams Cone(int rays = 0) {
  SdfParams p;
  p.rays = rays;
  return p;
}
SdfParams NormalRay() {
  SdfParams p;
  p.method = SdfMethod::kNormalRay;
  return p;
}

// Moves every vertex radially by a deterministic pseudo-random fraction of
// up to `amount`: a generic mesh, where no ray passes exactly through a
// vertex or an edge of the opposite side (on a perfectly symmetric mesh the
// normal ray of every vertex does, and the hit primitive switches under any
// perturbation: a true non-differentiable event).
// r(theta) = 1 + A sin(f theta), thesis §5.4.2.
Mesh NoisyCircle(int n, double amplitude, int frequency) {
  Mesh m = MakeCircle(1, n);
  for (Vec3& p : m.positions) {
    const double th = std::atan2(p.y, p.x);
    p *= 1 + amplitude * std::sin(frequency * th);
  }
  return m;
}

// g^T J from the Jacobian's rows, each coordinate summed exactly by the
// reference ExactSum (not the VJP's ExactSums) and rounded once.
std::vector<Vec3> ExactGTransposeJ(const SparseJacobian& jac,
                                   const std::vector<double>& g,
                                   int64_t vertices) {
  std::vector<ExactSum> sums(3 * vertices);
  for (size_t p = 0; p < g.size(); ++p) {
    for (int64_t k = jac.row_offsets[p]; k < jac.row_offsets[p + 1]; ++k) {
      const Vec3 d = jac.values[k] * g[p];
      for (int c = 0; c < 3; ++c) sums[3 * jac.columns[k] + c].Add(d[c]);
    }
  }
  std::vector<Vec3> out(vertices);
  for (int64_t j = 0; j < vertices; ++j) {
    for (int c = 0; c < 3; ++c) out[j][c] = sums[3 * j + c].Round();
  }
  return out;
}

TEST(SensitivityTest, Circle) {
  ExpectFdAgreement(
      CheckJacobian(MakeCircle(0.5, 64), Cone(), 64, "circle cone"));
  // Odd count: the normal ray of a vertex ends mid-segment, not on the
  // opposite vertex.
  ExpectFdAgreement(
      CheckJacobian(MakeCircle(0.5, 63), NormalRay(), 63, "circle normal"));
}

TEST(SensitivityTest, NoisyCircle) {
  ExpectFdAgreement(CheckJacobian(NoisyCircle(200, 0.05, 8), Cone(), 100,
                                  "noisy circle cone"));
  ExpectFdAgreement(CheckJacobian(NoisyCircle(200, 0.05, 8), NormalRay(), 100,
                                  "noisy circle normal"));
}

TEST(SensitivityTest, HollowSquareWithOutwardRegion) {
  const Mesh m = MakeHollowSquare(4, 1, 0.2);
  ExpectFdAgreement(CheckJacobian(m, Cone(), 60, "hollow cone"));
  ExpectFdAgreement(CheckJacobian(m, NormalRay(), 60, "hollow normal"));
}

TEST(SensitivityTest, Sphere) {
  ExpectFdAgreement(CheckJacobian(Jitter(MakeIcosphere(0.5, 4), 0.001), Cone(),
                                  30, "sphere cone"));
  ExpectFdAgreement(CheckJacobian(Jitter(MakeIcosphere(0.5, 4), 0.01),
                                  NormalRay(), 30, "jittered sphere normal"));
}

TEST(SensitivityTest, Torus) {
  ExpectFdAgreement(
      CheckJacobian(MakeTorus(1, 0.4, 32, 12), Cone(), 30, "torus cone"));
}

TEST(SensitivityTest, DecimatedKnight) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  ExpectFdAgreement(CheckJacobian(*mesh, Cone(), 30, "knight cone"));
  ExpectFdAgreement(CheckJacobian(*mesh, NormalRay(), 30, "knight normal"));
}

TEST(SensitivityTest, Spot) {
  auto mesh = ReadMesh(SharedMesh("spot_triangulated.obj"));
  ASSERT_TRUE(mesh.ok());
  ExpectFdAgreement(CheckJacobian(*mesh, Cone(), 12, "spot cone"));
}

TEST(SensitivityTest, QuadMesh) {
  // A box of quads (each grid cell one quad face), made generic.
  Mesh quads = MakeBox(2, 1, 0.5, 0.25, /*quads=*/true);
  quads = Jitter(quads, 0.01);
  ASSERT_TRUE(ValidateMesh(quads).ok());
  ExpectFdAgreement(CheckJacobian(quads, Cone(), 40, "quad box cone"));
}

TEST(SensitivityTest, VjpIsRotationEquivariantIn2D) {
  const Mesh m = NoisyCircle(150, 0.05, 5);
  const double angle = 0.7;
  const double c = std::cos(angle), s = std::sin(angle);
  Mesh rotated = m;
  for (Vec3& p : rotated.positions)
    p = Vec3(c * p.x - s * p.y, s * p.x + c * p.y, 0);
  std::vector<double> g(m.num_vertices());
  for (size_t i = 0; i < g.size(); ++i) g[i] = std::cos(0.3 * i);
  std::vector<Vec3> grads[2];
  std::vector<double> values[2];
  int i = 0;
  for (const Mesh* mesh : {&m, static_cast<const Mesh*>(&rotated)}) {
    auto ev = SdfEvaluator::Create(*mesh);
    ASSERT_TRUE(ev.ok());
    HitTable hits;
    auto r = (*ev)->Compute({}, {}, &hits);
    ASSERT_TRUE(r.ok());
    values[i] = r->values;
    grads[i++] = *ComputeVjp(**ev, hits, g);
  }
  for (size_t v = 0; v < g.size(); ++v) {
    EXPECT_NEAR(values[0][v], values[1][v], 1e-12);
    const Vec3& a = grads[0][v];
    const Vec3 ra(c * a.x - s * a.y, s * a.x + c * a.y, 0);
    EXPECT_NEAR(ra.x, grads[1][v].x, 1e-9);
    EXPECT_NEAR(ra.y, grads[1][v].y, 1e-9);
  }
}

TEST(SensitivityTest, VjpIsBitIdenticalForOneAndTwoThreads) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  auto ev = SdfEvaluator::Create(*mesh);
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute({}, {}, &hits).ok());
  std::vector<double> g(mesh->num_vertices(), 1.0);
  auto a = ComputeVjp(**ev, hits, g, {.threads = 1});
  auto b = ComputeVjp(**ev, hits, g, {.threads = 2});
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(*a, *b);
}

// Each Jacobian row holds one entry per vertex (a sample's rays hit the
// same primitives many times), and the VJP is exactly g^T J summed in sample
// order: out_j = sum_p g_p J_pj.
TEST(SensitivityTest, JacobianRowsHaveUniqueColumnsAndTheVjpIsGTransposeJ) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  auto ev = SdfEvaluator::Create(*mesh);
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute({}, {}, &hits).ok());
  auto jac = ComputeJacobian(**ev, hits);
  ASSERT_TRUE(jac.ok());
  // Every batch appended, the last included (about 3 batches here).
  ASSERT_EQ(std::ssize(jac->row_offsets), mesh->num_vertices() + 1);
  std::vector<double> g(mesh->num_vertices());
  for (size_t i = 0; i < g.size(); ++i) g[i] = std::cos(0.37 * i);
  int64_t repeated_hits = 0;
  for (int64_t p = 0; p < mesh->num_vertices(); ++p) {
    const auto row = hits.Row(p);
    std::vector<int32_t> prims;
    for (int32_t q : row) {
      if (q >= 0) prims.push_back(q);
    }
    std::sort(prims.begin(), prims.end());
    repeated_hits +=
        std::adjacent_find(prims.begin(), prims.end()) != prims.end();
    for (int64_t k = jac->row_offsets[p]; k < jac->row_offsets[p + 1]; ++k) {
      if (k > jac->row_offsets[p]) {
        ASSERT_LT(jac->columns[k - 1], jac->columns[k]) << "row " << p;
      }
    }
  }
  // The VJP's sums over samples are exact, rounded once.
  const std::vector<Vec3> expected =
      ExactGTransposeJ(*jac, g, mesh->num_vertices());
  EXPECT_GT(repeated_hits, mesh->num_vertices() / 2);
  auto vjp = ComputeVjp(**ev, hits, g);
  ASSERT_TRUE(vjp.ok());
  ASSERT_EQ(vjp->size(), expected.size());
  EXPECT_EQ(
      std::memcmp(vjp->data(), expected.data(), expected.size() * sizeof(Vec3)),
      0);
}

// JacobianBytesBound (what the server claims before ComputeJacobian) holds
// every Jacobian: vertex and face samples, quads, 2D, the inscribed ball;
// with 3 rays on a fine sphere the rays hit distinct primitives and the
// rows come close to it.
TEST(SensitivityTest, JacobianBytesBoundHoldsTheJacobian) {
  SdfParams cone, faces, ball, few;
  faces.samples = SampleSet::kFaces;
  ball.method = SdfMethod::kSphere;
  few.rays = 3;
  struct Case {
    Mesh mesh;
    SdfParams params;
  };
  const Case cases[] = {{*ReadMesh(SharedMesh("decimated-knight.off")), cone},
                        {MakeBox(1, 2, 3, 0.25, /*quads=*/true), faces},
                        {MakeBox(1, 2, 3, 0.25, /*quads=*/true), cone},
                        {MakeCircle(1, 64), cone},
                        {MakeCircle(1, 64), ball},
                        {MakeIcosphere(1, 8), ball},
                        {MakeIcosphere(1, 30), few}};
  for (const Case& c : cases) {
    auto ev = SdfEvaluator::Create(c.mesh);
    ASSERT_TRUE(ev.ok()) << ev.status();
    HitTable hits;
    ASSERT_TRUE((*ev)->Compute(c.params, {}, &hits).ok());
    auto bound = JacobianBytesBound(**ev, hits);
    auto jac = ComputeJacobian(**ev, hits);
    ASSERT_TRUE(bound.ok() && jac.ok());
    const int64_t bytes =
        jac->nonzeros() * (4 + 24) + std::ssize(jac->row_offsets) * 8;
    EXPECT_LE(bytes, *bound) << c.mesh.num_vertices() << " vertices";
    if (c.params.rays == 3) {
      EXPECT_GE(2 * bytes, *bound) << "fine sphere";
    }
  }
}

// Progress follows the batches at most once a percent, as ComputeControl
// promises: 1024 rays on this sphere make a few hundred batches.
TEST(SensitivityTest, VjpProgressIsReportedAtMostOncePerPercent) {
  const Mesh sphere = MakeIcosphere(1, 25);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  SdfParams params;
  params.rays = 1024;
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute(params, {}, &hits).ok());
  int64_t calls = 0, last = 0;
  ComputeControl control;
  control.progress = [&](int64_t done, int64_t) {
    EXPECT_GT(done, last);
    last = done;
    ++calls;
  };
  const std::vector<double> g(sphere.num_vertices(), 1.0);
  ASSERT_TRUE(ComputeVjp(**ev, hits, g, control).ok());
  EXPECT_EQ(last, sphere.num_vertices());
  EXPECT_LE(calls, 101);
}

// A VJP's rows are made a batch at a time, at most 1024 samples and 2^16
// row entries by their bounds: with 1024 rays a batch holds fewer samples
// (its memory is bounded whatever the ray count), with one ray 1024.
TEST(SensitivityTest, AVjpBatchIsBoundedByItsRowsNotOnlyItsSamples) {
  const Mesh sphere = MakeIcosphere(1, 15);
  auto ev = SdfEvaluator::Create(sphere);
  ASSERT_TRUE(ev.ok());
  // One ray: rows of a few entries, batches of 1024 samples; 1024 rays:
  // the rows' bounds cut a batch far sooner.
  for (int rays : {1, 1024}) {
    SdfParams params;
    params.rays = rays;
    HitTable hits;
    ASSERT_TRUE((*ev)->Compute(params, {}, &hits).ok());
    int64_t last = 0, widest = 0;
    ComputeControl control;
    control.progress = [&](int64_t done, int64_t total) {
      EXPECT_EQ(total, sphere.num_vertices());
      widest = std::max(widest, done - last);
      last = done;
    };
    const std::vector<double> g(sphere.num_vertices(), 1.0);
    ASSERT_TRUE(ComputeVjp(**ev, hits, g, control).ok());
    EXPECT_EQ(last, sphere.num_vertices());
    if (rays == 1) {
      EXPECT_EQ(widest, 1024);
    } else {
      EXPECT_LT(widest, 1024);
    }
  }
}

// A sample of weight 0 adds nothing to a VJP, so the VJP computes the
// rows of the others alone (a one-sided penalty's weights are 0 away from its
// thin parts): its progress counts them, and its result is still exactly g^T J
// (summed here by the reference ExactSum from the Jacobian's rows), for
// vertex and face samples; weights all 0 give zero vectors and no work,
// and a cancelled call is still Cancelled.
TEST(SensitivityTest, AVjpComputesOnlyTheRowsOfSamplesWithAWeight) {
  auto mesh = ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok());
  auto ev = SdfEvaluator::Create(*mesh);
  ASSERT_TRUE(ev.ok());
  for (SampleSet samples : {SampleSet::kVertices, SampleSet::kFaces}) {
    SdfParams params;
    params.samples = samples;
    params.rays = 30;
    HitTable hits;
    ASSERT_TRUE((*ev)->Compute(params, {}, &hits).ok());
    auto jac = ComputeJacobian(**ev, hits);
    ASSERT_TRUE(jac.ok());
    const int64_t n = std::ssize(jac->row_offsets) - 1;
    std::vector<double> g(n, 0.0);
    int64_t weighted = 0;
    for (int64_t p = 0; p < n; p += 7, ++weighted) g[p] = std::cos(0.37 * p);
    const std::vector<Vec3> expected =
        ExactGTransposeJ(*jac, g, mesh->num_vertices());
    int64_t total = 0, last = 0;
    ComputeControl control;
    control.progress = [&](int64_t done, int64_t all) {
      last = done;
      total = all;
    };
    auto vjp = ComputeVjp(**ev, hits, g, control);
    ASSERT_TRUE(vjp.ok());
    EXPECT_EQ(total, weighted);
    EXPECT_EQ(last, weighted);
    ASSERT_EQ(vjp->size(), expected.size());
    EXPECT_EQ(std::memcmp(vjp->data(), expected.data(),
                          expected.size() * sizeof(Vec3)),
              0);
    int64_t calls = 0;
    control.progress = [&](int64_t, int64_t) { ++calls; };
    auto zero = ComputeVjp(**ev, hits, std::vector<double>(n, 0.0), control);
    ASSERT_TRUE(zero.ok());
    EXPECT_EQ(calls, 0);
    for (const Vec3& v : *zero) EXPECT_EQ(v, Vec3());
    // Nothing to compute is still cancellable.
    control.cancelled = [] { return true; };
    EXPECT_EQ(ComputeVjp(**ev, hits, std::vector<double>(n, 0.0), control)
                  .status()
                  .code(),
              absl::StatusCode::kCancelled);
  }
}

TEST(SensitivityTest, RejectsHitTableOfAnotherGeneration) {
  const Mesh sphere = MakeIcosphere(1, 2);
  auto ev = SdfEvaluator::Create(sphere);
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute({}, {}, &hits).ok());
  std::vector<Vec3> moved = sphere.positions;
  for (Vec3& p : moved) p *= 1.1;
  ASSERT_TRUE((*ev)->UpdatePositions(moved).ok());
  const absl::Status s = ComputeJacobian(**ev, hits).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(s.message()), ::testing::HasSubstr("generation 1"));
  EXPECT_EQ(ComputeJacobian(**ev, HitTable{}).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

TEST(SensitivityTest, RejectsAngleWeightedNormals) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 2));
  SdfParams p;
  p.normal_weighting = NormalWeighting::kAngle;
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute(p, {}, &hits).ok());
  const absl::Status s = ComputeJacobian(**ev, hits).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(s.message()), ::testing::HasSubstr("area-weighted"));
}

TEST(SensitivityTest, RejectsBadVjpWeights) {
  auto ev = SdfEvaluator::Create(MakeIcosphere(1, 2));
  HitTable hits;
  ASSERT_TRUE((*ev)->Compute({}, {}, &hits).ok());
  EXPECT_EQ(ComputeVjp(**ev, hits, std::vector<double>(3, 1.0)).status().code(),
            absl::StatusCode::kInvalidArgument);
  std::vector<double> g(42, 1.0);
  g[5] = std::nan("");
  EXPECT_EQ(ComputeVjp(**ev, hits, g).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace meshgauge
