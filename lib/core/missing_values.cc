#include "lib/core/missing_values.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lib/core/components.h"
#include "lib/core/integrals.h"

namespace meshgauge {

MissingValues CountMissing(const Mesh& mesh,
                           const std::vector<double>& values) {
  MissingValues m;
  std::vector<uint8_t> on_face(mesh.num_vertices(), 0);
  double total = 0, missing = 0;
  int64_t last_face = -1;
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    bool finite = true;
    for (int i = 0; i < e.n; ++i) {
      on_face[e.v[i]] = 1;
      finite &= std::isfinite(values[e.v[i]]);
    }
    total += e.measure;
    if (finite) return;
    missing += e.measure;
    if (face != last_face) ++m.faces;
    last_face = face;
  });
  for (int64_t v = 0; v < mesh.num_vertices(); ++v) {
    m.vertices += on_face[v] && !std::isfinite(values[v]);
  }
  m.area_fraction = total > 0 ? missing / total : 0;
  return m;
}

MissingValues CountMissingFaces(const Mesh& mesh,
                                const std::vector<double>& values) {
  MissingValues m;
  double total = 0, missing = 0;
  int64_t last_face = -1;
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    total += e.measure;
    if (std::isfinite(values[face])) return;
    missing += e.measure;
    if (face != last_face) ++m.faces;
    last_face = face;
  });
  m.area_fraction = total > 0 ? missing / total : 0;
  return m;
}

std::string TooSmallToTrace(double extent) {
  return absl::StrFormat(
      "it is %.3g across, below the %.0e the ray tracer resolves: its "
      "single-precision intersection tests underflow there and rays lose "
      "their hits (NO_HIT); scale the mesh up (e.g. to millimetres or "
      "micrometres)",
      extent, kMinTracedExtent);
}

std::string LikelyMissingCause(const Mesh& mesh, const MissingCauses& causes) {
  if (const double extent = BoundingExtent(mesh);
      extent > 0 && extent < kMinTracedExtent) {
    return absl::StrCat("the mesh is tiny: ", TooSmallToTrace(extent));
  }
  const bool closed = IsClosed(mesh);
  if (closed && SignedVolume(mesh) < 0) {
    return "the mesh is closed with a negative signed volume, so its faces "
           "point inward and the cones look outside: reorient it "
           "(--reorient)";
  }
  if (causes.degenerate_normal > causes.no_hit) {
    return "most of those vertices have a degenerate normal "
           "(DEGENERATE_NORMAL): the mesh is probably double-sided "
           "(coincident opposite faces)";
  }
  if (!closed) {
    if (DiagnoseMesh(mesh).boundary_edges == 0) {
      return "the mesh has no boundary, but edges shared by more than two "
             "faces (duplicated, double-sided or touching faces), where "
             "normals cancel or point astray: remove the duplicates";
    }
    return "the mesh is open or planar, so most rays escape (NO_HIT): close "
           "it, or give the open regions an OUTWARD direction";
  }
  return absl::StrCat("the mesh is closed and outward, so ",
                      kCornerRaysLost);
}

absl::Status CheckMissing(const Mesh& mesh, const MissingValues& missing,
                          const MissingCauses& causes, double max_fraction,
                          const std::string& what) {
  if (missing.area_fraction <= max_fraction) return absl::OkStatus();
  return absl::FailedPreconditionError(absl::StrFormat(
      "%s over a surface whose values are mostly missing: %d vertices "
      "without a value, %.1f%% of the area skipped (allowed %.1f%%); %s",
      what, missing.vertices, 100 * missing.area_fraction, 100 * max_fraction,
      LikelyMissingCause(mesh, causes)));
}

}  // namespace meshgauge
