#include "lib/core/missing_diagnosis.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lib/core/box.h"
#include "lib/core/components.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_values.h"

namespace meshgauge {
namespace {

struct ComponentMissing {
  int64_t component = 0;
  double area = 0, missing_area = 0;
  int64_t missing_vertices = 0, no_hit = 0, degenerate = 0;
  Vec3 area_vector;       // sum of the faces' area vectors (3D).
  double area_norms = 0;  // sum of their lengths.
  Box box;                // of its faces' vertices.
};

// Below this share of the mesh's bounding-box diagonal a component spans
// fewer than about 2^7 steps of the tracer's single precision, whose
// coordinates reach about twice the diagonal (SceneOrigin).
constexpr double kUnresolvedShare = 0x1p-16;

std::string Cause(const Mesh& mesh, const Component& c,
                  const ComponentMissing& m, bool inconsistent,
                  double diagonal) {
  const double span = Norm(m.box.hi - m.box.lo);
  if (span > 0 && span < kMinTracedExtent) return TooSmallToTrace(span);
  if (span < kUnresolvedShare * diagonal) {
    return absl::StrFormat(
        "it spans %.3g while the mesh spans %.3g, where the ray tracer's "
        "single-precision coordinates step by about %.3g (trace it on its "
        "own, or bring the parts closer)",
        span, diagonal, diagonal * 0x1p-23);
  }
  if (c.inverted()) {
    return "it is closed and turned inside out (an outer shell with a "
           "negative signed volume, or a cavity's shell facing out of its "
           "cavity): its faces point into the solid and the cones look out "
           "of the material (--reorient, or reorient in the Python client)";
  }
  if (inconsistent) {
    return "neighbouring faces disagree on orientation, so normals there "
           "are wrong or cancel (--reorient makes it consistent)";
  }
  if (m.degenerate > m.no_hit) {
    return "most of its missing vertices have a degenerate normal: "
           "double-sided or folded faces whose normals cancel";
  }
  if (!c.closed && c.boundary_edges == 0) {
    return mesh.dimension == 2
               ? "it has no open end, but vertices shared by more than two "
                 "segments (a duplicated or touching segment), where normals "
                 "cancel or point astray (remove the duplicates)"
               : "it has no boundary, but edges shared by more than two "
                 "faces (a duplicated, double-sided or touching face), where "
                 "normals cancel or point astray (remove the duplicates)";
  }
  if (mesh.dimension == 3 && !c.closed &&
      Norm(m.area_vector) >= (1 - 1e-9) * m.area_norms) {
    return "it is a flat sheet with no inside, so the rays escape (thicken "
           "it, or give its region an OUTWARD cone)";
  }
  if (!c.closed) {
    return "it is open, so rays escape through its holes (close it, or give "
           "open regions an OUTWARD cone)";
  }
  return absl::StrCat("it is closed and outward, so ", kCornerRaysLost);
}

// Per component: its measure, box and area vectors, and the measure and
// vertices without a value (each missing vertex counted once, in the
// component of its first face). *total: the surface's measure.
std::vector<ComponentMissing> MissingPerComponent(
    const Mesh& mesh, const std::vector<Component>& components,
    const std::vector<double>& values, const std::vector<VertexStatus>& status,
    double* total) {
  std::vector<int32_t> component_of(mesh.faces.size());
  std::vector<ComponentMissing> per(components.size());
  for (size_t i = 0; i < components.size(); ++i) {
    per[i].component = static_cast<int64_t>(i);
    for (int32_t f : components[i].faces) {
      component_of[f] = static_cast<int32_t>(i);
    }
  }
  *total = 0;
  ForEachElement(mesh, [&](int64_t face, const Element& e) {
    ComponentMissing& m = per[component_of[face]];
    bool finite = true;
    for (int i = 0; i < e.n; ++i) finite &= std::isfinite(values[e.v[i]]);
    *total += e.measure;
    m.area += e.measure;
    for (int i = 0; i < e.n; ++i) {
      m.box.Extend(mesh.positions[e.v[i]], mesh.positions[e.v[i]]);
    }
    if (!finite) m.missing_area += e.measure;
    if (e.n == 3) {
      const Vec3& a = mesh.positions[e.v[0]];
      const Vec3 n =
          Cross(mesh.positions[e.v[1]] - a, mesh.positions[e.v[2]] - a) * 0.5;
      m.area_vector += n;
      m.area_norms += Norm(n);
    }
  });
  std::vector<int32_t> vertex_component(mesh.positions.size(), -1);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int k = 0; k < mesh.faces[f].size; ++k) {
      int32_t& c = vertex_component[mesh.faces[f].v[k]];
      if (c < 0) c = component_of[f];
    }
  }
  for (size_t v = 0; v < values.size(); ++v) {
    if (vertex_component[v] < 0 || std::isfinite(values[v])) continue;
    ComponentMissing& m = per[vertex_component[v]];
    ++m.missing_vertices;
    m.no_hit += status[v] == VertexStatus::kNoHit;
    m.degenerate += status[v] == VertexStatus::kDegenerateNormal;
  }
  return per;
}

// The components missing more than warn_fraction of the surface's measure
// `total`, the largest missing measure first (ties: lowest component).
std::vector<ComponentMissing> Flagged(const std::vector<ComponentMissing>& per,
                                      double total, double warn_fraction) {
  std::vector<ComponentMissing> flagged;
  for (const ComponentMissing& m : per) {
    if (total > 0 && m.missing_area > warn_fraction * total) {
      flagged.push_back(m);
    }
  }
  std::sort(flagged.begin(), flagged.end(), [](const auto& a, const auto& b) {
    return a.missing_area != b.missing_area ? a.missing_area > b.missing_area
                                            : a.component < b.component;
  });
  return flagged;
}

}  // namespace

std::vector<std::string> MissingValueWarnings(
    const Mesh& mesh, const std::vector<double>& values,
    const std::vector<VertexStatus>& status, double warn_fraction) {
  // Nothing missing, nothing flagged: skip the components (a full topology
  // pass, about half a second on a million vertices).
  if (warn_fraction >= 0 &&
      std::all_of(values.begin(), values.end(),
                  [](double v) { return std::isfinite(v); })) {
    return {};
  }
  const std::vector<Component> components = ConnectedComponents(mesh);
  double total = 0;
  const std::vector<ComponentMissing> per =
      MissingPerComponent(mesh, components, values, status, &total);
  const std::vector<ComponentMissing> flagged =
      Flagged(per, total, warn_fraction);
  std::vector<int64_t> inconsistent;
  if (!flagged.empty())
    inconsistent = DiagnoseMesh(mesh).inconsistent_components;
  std::vector<std::string> out;
  const double diagonal = BoundingBoxDiagonal(mesh);
  constexpr size_t kNamed = 5;
  for (size_t i = 0; i < flagged.size() && i < kNamed; ++i) {
    const ComponentMissing& m = flagged[i];
    const Component& c = components[m.component];
    const bool mixed = std::binary_search(inconsistent.begin(),
                                          inconsistent.end(), m.component);
    out.push_back(absl::StrFormat(
        "component %d (%d faces): %.3g%% of its %s (%.3g%% of the mesh's) "
        "has no value, %d vertices: %s",
        m.component, c.faces.size(), 100 * m.missing_area / m.area,
        mesh.dimension == 2 ? "length" : "area", 100 * m.missing_area / total,
        m.missing_vertices, Cause(mesh, c, m, mixed, diagonal)));
  }
  if (flagged.size() > kNamed) {
    out.push_back(absl::StrFormat(
        "%d more components have more than %.3g%% of the surface without "
        "values",
        flagged.size() - kNamed, 100 * warn_fraction));
  }
  return out;
}

std::vector<std::string> MissingValueWarnings(const Mesh& mesh,
                                              const SdfResult& result,
                                              double warn_fraction) {
  if (result.resolved.params.samples == SampleSet::kVertices) {
    // A component's missing area is a sum of some of the terms of the
    // surface's, in the same order, so it is never larger: with the
    // surface's share under the threshold (a margin for the rounding of the
    // share) no component is named, and its topology pass is skipped.
    if (warn_fraction >= 0 &&
        result.missing.area_fraction <= warn_fraction * (1 - 1e-9)) {
      return {};
    }
    return MissingValueWarnings(mesh, result.values, result.status,
                                warn_fraction);
  }
  if (!(result.missing.area_fraction > warn_fraction)) return {};
  return {absl::StrFormat("%d faces (%.2f%% of the surface) have no value: %s",
                          result.missing.faces,
                          100 * result.missing.area_fraction,
                          LikelyMissingCause(mesh, result.Causes()))};
}

}  // namespace meshgauge
