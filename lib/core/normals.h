// Vertex normals of SPEC §2.
#pragma once

#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/topology.h"

namespace meshgauge {

enum class NormalWeighting {
  kArea,   // N_p = sum over triangles containing p of (b-a) x (c-a); 2D:
           // sum over segments of perp(b-a). Differentiable (SPEC §6).
  kAngle,  // N_p = sum of unit face normals weighted by the corner angle at
           // p (3D only; 2D falls back to length weighting). Values only: no
           // derivative is provided for it.
};

// Unnormalised vertex normal N_p for every vertex, in mesh units^2 (3D,
// area weighting), mesh units (2D) or radians (angle weighting). Vertices on
// no face get (0, 0, 0).
std::vector<Vec3> UnnormalizedNormals(const Mesh& mesh,
                                      const MeshTopology& topo,
                                      NormalWeighting weighting);
// The same for vertex `p` alone (bit-identical to UnnormalizedNormals()[p]),
// for a pass that needs each normal once and need not hold #V of them.
Vec3 UnnormalizedNormal(const Mesh& mesh, const MeshTopology& topo, int64_t p,
                        NormalWeighting weighting);

// The contribution of one primitive to N_p (area weighting) and its
// vector-Jacobian product: for a covector g on N_p's contribution, adds
// g^T d(contribution)/d x_j to grad[j] for the primitive's vertices.
Vec3 PrimitiveNormal(const Mesh& mesh, const Primitive& prim);
void PrimitiveNormalVjp(const Mesh& mesh, const Primitive& prim, const Vec3& g,
                        Vec3 grad_out[3]);

}  // namespace meshgauge
