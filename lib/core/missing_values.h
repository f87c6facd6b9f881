// Vertices without a value and the surface they cost the integrals (SPEC v2
// §7: missing values are never a silent zero).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "lib/core/mesh.h"

namespace meshgauge {

struct MissingValues {
  int64_t vertices = 0;      // vertices on a face but without a value.
  int64_t faces = 0;         // faces with such a vertex (integrals skip them).
  double area_fraction = 0;  // their measure / the whole surface's, [0, 1].
};

// values: #V, NaN where there is no value. Vertices on no face are not
// counted (they have no surface). Precondition: mesh validated.
MissingValues CountMissing(const Mesh& mesh, const std::vector<double>& values);

// The same for face samples (SPEC v2 §5c): values has #F entries; faces
// counts those without a value, vertices stays 0.
MissingValues CountMissingFaces(const Mesh& mesh,
                                const std::vector<double>& values);

// Counts of the statuses of the vertices without a value, for the diagnosis.
struct MissingCauses {
  int64_t no_hit = 0;
  int64_t degenerate_normal = 0;
};

// Why a closed, outward mesh loses values, and the fixes (the end of a
// sentence): at a sharp corner of a coarse mesh the cone leaves the solid
// through the one-ring's faces, which rays ignore.
inline constexpr char kCornerRaysLost[] =
    "these are rays lost at sharp or coarse corners: there the vertex "
    "normal leans towards the side with more triangles and the cone leaves "
    "the solid through the vertex's own faces, which rays ignore (NO_HIT); "
    "measure face samples (--samples faces, samples=\"faces\": each face "
    "along its own normal, as CAD parts need), refine the mesh there, or "
    "widen the cone (--cone-angle 60) so that some rays stay inside";

// Below this bounding-box extent (mesh units) the ray tracer's
// single-precision intersection tests underflow (products of three
// coordinates fall under float's smallest normal, about 1e-38, and are
// flushed to zero): rays find no hits. Measured: a sphere 2e-14 across is
// measured, one 2e-15 across gets no value; the limit keeps a margin.
inline constexpr double kMinTracedExtent = 1e-12;

// The sentence that names that cause for a part `extent` across.
std::string TooSmallToTrace(double extent);

// A one-sentence likely cause of missing values: inward orientation
// (negative signed volume of a closed mesh: reorient), a double-sided mesh
// (most missing vertices have a degenerate normal), edges shared by more
// than two faces (not closed, no boundary; a topology pass), or an open or
// planar mesh (rays escape). Precondition: mesh validated.
std::string LikelyMissingCause(const Mesh& mesh, const MissingCauses& causes);

// OK when missing.area_fraction <= max_fraction; otherwise
// FailedPrecondition naming `what`, the fraction, the allowed fraction and
// the likely cause.
absl::Status CheckMissing(const Mesh& mesh, const MissingValues& missing,
                          const MissingCauses& causes, double max_fraction,
                          const std::string& what);

}  // namespace meshgauge
