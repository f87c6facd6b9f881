// Whole passes compared bit for bit (ray starts, traversals).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/strings/str_cat.h"
#include "absl/types/span.h"
#include "lib/core/components.h"
#include "lib/core/hit_table.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "tests/test_util.h"

namespace meshgauge::testing {

struct Pass {
  SdfResult result;
  HitTable hits;
};

// A fresh evaluator's pass on 2 threads, with its hit table (empty, with a
// failure, when it fails).
inline Pass PassFrom(const Mesh& mesh, const SdfParams& params,
                     const EvaluatorOptions& options) {
  Pass pass;
  auto ev = SdfEvaluator::Create(mesh, options);
  if (!ev.ok()) {
    ADD_FAILURE() << ev.status();
    return pass;
  }
  auto r = (*ev)->Compute(params, {.threads = 2}, &pass.hits);
  if (!r.ok()) {
    ADD_FAILURE() << r.status();
    return pass;
  }
  pass.result = *std::move(r);
  return pass;
}

// The results of both passes (values, opposite points, statuses, counts)
// and which rays their hit tables keep, bit for bit.
inline void ExpectSameResults(const Pass& a, const Pass& b,
                              const std::string& what) {
  EXPECT_TRUE(SameBits(a.result.values, b.result.values)) << what;
  EXPECT_TRUE(SameBits(a.result.opposite, b.result.opposite)) << what;
  EXPECT_EQ(a.result.status, b.result.status) << what;
  EXPECT_EQ(a.result.hits, b.result.hits) << what;
  EXPECT_EQ(a.result.kept, b.result.kept) << what;
  EXPECT_EQ(a.hits.kept, b.hits.kept) << what;
}

// The result, the hit table and its near flags of both passes, bit for bit.
inline void ExpectSameBits(const Pass& a, const Pass& b,
                           const std::string& what) {
  ExpectSameResults(a, b, what);
  EXPECT_EQ(a.hits.primitives, b.hits.primitives) << what;
  EXPECT_EQ(a.hits.near, b.hits.near) << what;
}

// ExpectSameResults, and hit tables that differ only where two tracers'
// single-precision tests may (docs/numerics.md "The cone walk"): a ray
// whose primitives differ met both at a corner they share, at the same
// distance (the values are the same bits); near flags differ in under 1 %
// of the samples (a primitive within rounding of the sample).
inline void ExpectSameResultsUpToTies(const Mesh& mesh, const Pass& a,
                                      const Pass& b, const std::string& what) {
  ExpectSameResults(a, b, what);
  ASSERT_EQ(a.hits.primitives.size(), b.hits.primitives.size()) << what;
  const MeshTopology topo = MeshTopology::Build(mesh);
  for (size_t i = 0; i < a.hits.primitives.size(); ++i) {
    const int32_t p = a.hits.primitives[i], q = b.hits.primitives[i];
    if (p == q) continue;
    ASSERT_TRUE(p >= 0 && q >= 0) << what << ": ray " << i;
    bool share = false;
    for (int32_t u : topo.primitives[p].v) {
      for (int32_t v : topo.primitives[q].v) share |= u >= 0 && u == v;
    }
    EXPECT_TRUE(share) << what << ": ray " << i << " met " << p << " and " << q;
  }
  ASSERT_EQ(a.hits.near.size(), b.hits.near.size()) << what;
  int64_t near_differ = 0;
  for (size_t i = 0; i < a.hits.near.size(); ++i) {
    near_differ += a.hits.near[i] != b.hits.near[i];
  }
  EXPECT_LE(100 * near_differ, std::ssize(a.hits.near)) << what;
}

// The samples a pass traced: those with faces and a cone.
inline int64_t Traced(const SdfResult& r) {
  return std::ssize(r.values) - r.CountStatus(VertexStatus::kNoFaces) -
         r.CountStatus(VertexStatus::kDegenerateNormal);
}

inline constexpr Vec3 kMove(1e-3, -2e-3, 1e-3);

// `mesh` with the vertices `patch` moved by kMove.
inline Mesh Moved(const Mesh& mesh, const std::vector<int32_t>& patch) {
  Mesh at = mesh;
  for (int32_t v : patch) at.positions[v] += kMove;
  return at;
}

// The incremental pass of `ev` after the vertices `patch` of `mesh` moved,
// from a pass at the original positions (empty, with a failure, when a
// step fails).
inline Pass IncrementalPass(SdfEvaluator& ev, const Mesh& mesh,
                            const std::vector<int32_t>& patch,
                            const SdfParams& params) {
  Pass last, next;
  auto first = ev.Compute(params, {}, &last.hits);
  absl::Status moved = first.ok()
                           ? ev.UpdatePositions(Moved(mesh, patch).positions)
                           : first.status();
  if (!moved.ok()) {
    ADD_FAILURE() << moved;
    return next;
  }
  last.result = *std::move(first);
  const PreviousPass previous{&last.result, &last.hits};
  auto r = ev.Compute(params, {}, &next.hits, &previous);
  if (!r.ok()) {
    ADD_FAILURE() << r.status();
    return next;
  }
  next.result = *std::move(r);
  EXPECT_LT(next.result.rays_traced, last.result.rays_traced);
  return next;
}

// For each named test mesh (faces turned outward: the horse's turn inward,
// and its rays would leave the part) at 30° and 60°: `check` with the mesh,
// 24-ray parameters with opposite points, and "NAME at ANGLE degrees".
inline void ForEachTestMeshAndAngle(
    absl::Span<const char* const> names,
    absl::FunctionRef<void(const Mesh&, const SdfParams&, const std::string&)>
        check) {
  for (const char* name : names) {
    auto mesh = ReadMesh(SharedMesh(name));
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    ReorientComponents(*mesh);
    for (double angle : {30.0, 60.0}) {
      SdfParams params;
      params.rays = 24;
      params.cone_angle_degrees = angle;
      params.opposite_points = true;
      check(*mesh, params, absl::StrCat(name, " at ", angle, " degrees"));
    }
  }
}

}  // namespace meshgauge::testing
