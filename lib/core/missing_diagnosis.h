// Why a ray pass left values missing, per connected component (SPEC v2 §7:
// missing values are never silent).
#pragma once

#include <string>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

// Share of the surface without values above which MissingValueWarnings
// warns by default (the error threshold of penalties is SPEC v2 §7's).
inline constexpr double kWarnMissingFraction = 0.01;

// One sentence per connected component whose faces without values cover
// more than `warn_fraction` of the whole surface, naming the likely cause
// for that component, the first that applies: a component too small for
// the ray tracer's single precision at the mesh's scale (spanning under
// 2^-16 of its diagonal, as a part far from the others), faces pointing
// inward (closed, negative volume), neighbours of disagreeing orientation,
// double-sided or folded faces (degenerate normals), edges shared by more
// than two faces (not closed, but no boundary), a flat sheet, an open
// component, or else rays lost at sharp or coarse corners (the one-ring
// exclusion's shadow). The five
// components with the most missing area are named, then how many more.
// values and status: #V, of one ray pass. Precondition: mesh validated.
// O(F log F).
std::vector<std::string> MissingValueWarnings(
    const Mesh& mesh, const std::vector<double>& values,
    const std::vector<VertexStatus>& status,
    double warn_fraction = kWarnMissingFraction);

// The warnings of a pass: MissingValueWarnings for vertex samples; for face
// samples (SPEC v2 §5c) one sentence, with the likely cause, when the faces
// without a value cover more than `warn_fraction` of the surface. Linear
// and without a topology pass when result.missing (the pass's CountMissing)
// covers at most `warn_fraction` of the surface, as no component can then be
// named.
std::vector<std::string> MissingValueWarnings(
    const Mesh& mesh, const SdfResult& result,
    double warn_fraction = kWarnMissingFraction);

}  // namespace meshgauge
