// Face samples (SPEC v2 §5c): the SDF at a face's centroid, looking along
// the face's own normal, shared by the value pass and the sensitivities.
#pragma once

#include <cstdint>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"

namespace meshgauge {

// How many samples `set` has on `mesh`: #V or #F.
inline int64_t NumSamples(const Mesh& mesh, SampleSet set) {
  return set == SampleSet::kFaces ? mesh.num_faces() : mesh.num_vertices();
}

// The samples [begin, end) of params.range on `mesh` (every sample for the
// default range). InvalidArgument naming the range and the sample count
// unless 0 <= begin < end <= NumSamples.
absl::StatusOr<SampleRange> ResolveRange(const Mesh& mesh,
                                         const SdfParams& params);

// The mean of face f's corners (a quad's four, a segment's two).
Vec3 FaceCentroid(const Mesh& mesh, int64_t f);

// Sample p of `set`: where it sits and its cone, for the value pass and the
// sensitivities alike.
//  * A vertex: x_p, and MakeVertexCone of N_p = normal_sum() (SPEC §2-3).
//  * A face: its centroid, and axis = sign N_f/|N_f| with N_f the sum of
//    the area normals (PrimitiveNormal) of f's primitives and the sign of
//    f's region's direction; in 3D the frame attached (SPEC v2 §3) to the
//    first of f's corners in increasing index seen from the centroid (any
//    corner of a planar face qualifies), in 2D the world frame.
// With `frame` false the cone has its axis only (the inscribed ball needs
// no rays). Not valid when N is 0 (a face of a validated mesh never is).
struct SampleCone {
  VertexCone cone;
  Vec3 x;
};
SampleCone MakeSampleCone(const Mesh& mesh, const MeshTopology& topo,
                          SampleSet set, int64_t p,
                          absl::FunctionRef<Vec3()> normal_sum, bool frame);

// What sample p of `set` ignores, ascending and unique, into `out`: for a
// vertex its one-ring's primitives (SPEC §4; the inscribed ball likewise);
// for a face, its own primitives, or with `ball` those of every face
// sharing a vertex with it (SPEC v2 §5c).
void SampleExclusions(const Mesh& mesh, const MeshTopology& topo, SampleSet set,
                      bool ball, int64_t p, std::vector<int32_t>* out);

}  // namespace meshgauge
