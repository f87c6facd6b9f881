// Face samples (SPEC v2 §5c): the SDF at a face's centroid, looking along
// the face's own normal, shared by the value pass and the sensitivities.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"
#include "lib/core/topology.h"
#include "lib/core/vertex_cone.h"

namespace meshgauge {

// How many samples `set` has on `mesh`: #V or #F.
inline int64_t NumSamples(const Mesh& mesh, SampleSet set) {
  return set == SampleSet::kFaces ? mesh.num_faces() : mesh.num_vertices();
}

// The mean of face f's corners (a quad's four, a segment's two).
Vec3 FaceCentroid(const Mesh& mesh, int64_t f);

// The cone of face f: axis = sign N_f/|N_f| with N_f the sum of the area
// normals (PrimitiveNormal) of f's primitives and the sign of f's region's
// direction; in 3D the frame attached (SPEC v2 §3) to the first of f's
// corners in increasing index seen from the centroid (any corner of a
// planar face qualifies), in 2D the world frame. Not valid when N_f = 0 (a
// validated mesh has none).
VertexCone MakeFaceCone(const Mesh& mesh, const MeshTopology& topo, int64_t f);

// f's own primitives, ascending: what a ray from its centroid ignores.
void FacePrimitives(const MeshTopology& topo, int64_t f,
                    std::vector<int32_t>* out);

// The primitives of every face sharing a vertex with f (f's included),
// ascending and unique: what the inscribed ball at f's centroid ignores.
void FaceRingPrimitives(const Mesh& mesh, const MeshTopology& topo, int64_t f,
                        std::vector<int32_t>* out);

}  // namespace meshgauge
