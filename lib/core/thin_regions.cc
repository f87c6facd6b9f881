#include "lib/core/thin_regions.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "absl/strings/str_cat.h"
#include "lib/core/disjoint_sets.h"
#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"

namespace meshgauge {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The part of a simplex (segment or triangle) whose interpolated value is
// below s: a polygon of up to 4 points (2 for a segment).
struct Piece {
  std::array<Vec3, 4> p;
  int n = 0;
};

Piece ClipBelow(const Vec3* p, const double* v, int n, double s) {
  Piece out;
  if (n == 2) {
    if (v[0] >= s && v[1] >= s) return out;
    for (int i = 0; i < 2; ++i) {
      const int j = 1 - i;
      out.p[i] =
          v[i] < s ? p[i] : p[j] + (p[i] - p[j]) * ((s - v[j]) / (v[i] - v[j]));
    }
    out.n = 2;
    return out;
  }
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    const bool in_i = v[i] < s, in_j = v[j] < s;
    if (in_i) out.p[out.n++] = p[i];
    if (in_i != in_j) {
      out.p[out.n++] = p[i] + (p[j] - p[i]) * ((s - v[i]) / (v[j] - v[i]));
    }
  }
  return out;
}

// Measure and measure-weighted centroid of a clipped piece.
std::pair<double, Vec3> MeasureAndCentroid(const Piece& piece) {
  if (piece.n == 2) {
    return {Norm(piece.p[1] - piece.p[0]), (piece.p[0] + piece.p[1]) * 0.5};
  }
  double area = 0;
  Vec3 moment;
  for (int k = 1; k + 1 < piece.n; ++k) {
    const double a =
        0.5 * Norm(Cross(piece.p[k] - piece.p[0], piece.p[k + 1] - piece.p[0]));
    area += a;
    moment += (piece.p[0] + piece.p[k] + piece.p[k + 1]) * (a / 3);
  }
  return {area, area > 0 ? moment / area : piece.p[0]};
}

// Values per vertex, or per face (constant on it): the value at a corner.
struct Field {
  const std::vector<double>& values;
  bool faces = false;
  double At(int64_t face, int32_t vertex) const {
    return values[faces ? face : vertex];
  }
};

// The corner positions and values of an integration element of `face`.
struct Corners {
  std::array<Vec3, 3> p;
  std::array<double, 3> v;
};

Corners CornersOf(const Mesh& mesh, const Field& field, int64_t face,
                  const Element& e) {
  Corners c;
  for (int k = 0; k < e.n; ++k) {
    c.p[k] = mesh.positions[e.v[k]];
    c.v[k] = field.At(face, e.v[k]);
  }
  return c;
}

bool HasValues(const Mesh& mesh, const Field& field, int64_t f) {
  const Face& face = mesh.faces[f];
  for (int k = 0; k < face.size; ++k) {
    if (std::isnan(field.At(f, face.v[k]))) return false;
  }
  return true;
}

// The measure of an element (of `measure`, values v) below s.
double MeasureBelow(double measure, const double* v, int n, double s) {
  if (n == 3) return TriangleAreaBelow(measure, v[0], v[1], v[2], s);
  const double lo = std::min(v[0], v[1]), hi = std::max(v[0], v[1]);
  if (s <= lo) return 0;
  if (s >= hi) return measure;
  return measure * (s - lo) / (hi - lo);
}

// Joins thin faces that share an edge (3D) or a vertex (2D) whose own
// interpolation falls below t_min (face values: any shared edge or vertex
// of two thin faces).
void JoinThinFaces(const Mesh& mesh, const Field& field,
                   const std::vector<char>& thin, double t_min,
                   std::vector<int32_t>& parent) {
  std::vector<std::pair<uint64_t, int32_t>> uses;
  for (int32_t f = 0; f < mesh.num_faces(); ++f) {
    if (!thin[f]) continue;
    const Face& face = mesh.faces[f];
    if (face.size == 2) {
      for (int k = 0; k < 2; ++k) {
        if (field.At(f, face.v[k]) < t_min) {
          uses.push_back({uint64_t(face.v[k]), f});
        }
      }
      continue;
    }
    for (int k = 0; k < face.size; ++k) {
      const int32_t a = face.v[k], b = face.v[(k + 1) % face.size];
      if (std::min(field.At(f, a), field.At(f, b)) >= t_min) continue;
      uses.push_back({EdgeKey(a, b), f});
    }
  }
  std::sort(uses.begin(), uses.end());
  for (size_t i = 1; i < uses.size(); ++i) {
    if (uses[i].first == uses[i - 1].first) {
      Unite(parent, uses[i].second, uses[i - 1].second);
    }
  }
}

absl::Status CheckValues(const Mesh& mesh, const std::vector<double>& values,
                         SampleSet samples) {
  const bool faces = samples == SampleSet::kFaces;
  if (const int64_t n = faces ? mesh.num_faces() : mesh.num_vertices();
      std::ssize(values) != n) {
    return absl::InvalidArgumentError(
        absl::StrCat("values has ", values.size(), " entries for ", n,
                     faces ? " faces" : " vertices"));
  }
  return absl::OkStatus();
}

}  // namespace

double TriangleAreaBelow(double area, double a, double b, double c, double s) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
  if (s <= a) return 0;
  if (s >= c) return area;
  if (s <= b) return area * ((s - a) / (b - a)) * ((s - a) / (c - a));
  return area - area * ((c - s) / (c - a)) * ((c - s) / (c - b));
}

namespace {

absl::Status CheckThinParams(const ThinRegionParams& params) {
  if (!(params.t_min > 0) || !std::isfinite(params.t_min)) {
    return absl::InvalidArgumentError(
        absl::StrCat("t_min must be positive and finite, got ", params.t_min));
  }
  if (!(params.min_region_area >= 0) ||
      !std::isfinite(params.min_region_area)) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_region_area must be >= 0 and finite, got ",
                     params.min_region_area));
  }
  return absl::OkStatus();
}

// Per face: whether all its corners have values, and whether one of them
// is below t_min.
struct FaceFlags {
  std::vector<char> valued, thin;
};

FaceFlags FlagFaces(const Mesh& mesh, const Field& field, double t_min) {
  const int32_t nf = static_cast<int32_t>(mesh.num_faces());
  FaceFlags flags{std::vector<char>(nf, 0), std::vector<char>(nf, 0)};
  for (int32_t f = 0; f < nf; ++f) {
    const Face& face = mesh.faces[f];
    flags.valued[f] = HasValues(mesh, field, f);
    if (!flags.valued[f]) continue;
    for (int k = 0; k < face.size; ++k) {
      if (field.At(f, face.v[k]) < t_min) flags.thin[f] = 1;
    }
  }
  return flags;
}

// The smallest value into out->min_*: a vertex's, or a face's (then at its
// centroid). out->min_thickness stays NaN when no sample has a value.
void FindMinimum(const Mesh& mesh, const Field& field, ThinSurface* out) {
  const std::vector<double>& values = field.values;
  int32_t min_sample = -1;
  for (int32_t i = 0; i < static_cast<int32_t>(values.size()); ++i) {
    if (!std::isnan(values[i]) &&
        (min_sample < 0 || values[i] < out->min_thickness)) {
      out->min_thickness = values[i];
      min_sample = i;
    }
  }
  if (min_sample >= 0 && field.faces) {
    out->min_face = min_sample;
    out->min_vertex = mesh.faces[min_sample].v[0];
    out->min_point = FaceCentroid(mesh, min_sample);
  } else if (min_sample >= 0) {
    out->min_vertex = min_sample;
    out->min_point = mesh.positions[min_sample];
  }
}

// The regions as they are found, in order of their lowest face id.
struct RegionsFound {
  std::vector<ThinRegion> regions;
  std::vector<int32_t> first_face;  // per region: its lowest face id.
  std::vector<Vec3> moment;  // per region: the measure-weighted centroids.
};

// Lowers r's minimum to face f's values.
void LowerMinimum(const Mesh& mesh, const Field& field, int32_t f,
                  ThinRegion& r) {
  if (field.faces) {
    if (r.min_face < 0 || field.values[f] < r.min_thickness) {
      r.min_thickness = field.values[f];
      r.min_face = f;
      r.min_vertex = mesh.faces[f].v[0];
    }
    return;
  }
  const Face& face = mesh.faces[f];
  for (int k = 0; k < face.size; ++k) {
    const int32_t v = face.v[k];
    const double t = field.values[v];
    if (r.min_vertex < 0 || t < r.min_thickness ||
        (t == r.min_thickness && v < r.min_vertex)) {
      r.min_thickness = t;
      r.min_vertex = v;
    }
  }
}

// A region per set of joined thin faces (`parent`), with its face count and
// minimum; face_region gets each thin face's region.
RegionsFound GroupThinFaces(const Mesh& mesh, const Field& field,
                            const std::vector<char>& thin,
                            std::vector<int32_t>& parent,
                            std::vector<int32_t>& face_region) {
  const int32_t nf = static_cast<int32_t>(mesh.num_faces());
  std::vector<int32_t> root_region(nf, -1);
  RegionsFound found;
  for (int32_t f = 0; f < nf; ++f) {
    if (!thin[f]) continue;
    const int32_t root = FindRoot(parent, f);
    if (root_region[root] < 0) {
      root_region[root] = static_cast<int32_t>(found.regions.size());
      ThinRegion r;
      r.box_min = {kInf, kInf, kInf};
      r.box_max = {-kInf, -kInf, -kInf};
      found.regions.push_back(r);
      found.first_face.push_back(f);
      found.moment.push_back({});
    }
    const int32_t id = root_region[root];
    face_region[f] = id;
    ThinRegion& r = found.regions[id];
    ++r.faces;
    LowerMinimum(mesh, field, f, r);
  }
  return found;
}

// Each region's area, moment and box: its parts below t_min, element by
// element in face order.
void MeasureParts(const Mesh& mesh, const Field& field, double t_min,
                  const std::vector<int32_t>& face_region,
                  RegionsFound& found) {
  ForEachElement(mesh, [&](int64_t f, const Element& e) {
    const int32_t id = face_region[f];
    if (id < 0) return;
    const Corners c = CornersOf(mesh, field, f, e);
    const Piece piece = ClipBelow(c.p.data(), c.v.data(), e.n, t_min);
    if (piece.n == 0) return;
    const auto [m, centre] = MeasureAndCentroid(piece);
    ThinRegion& r = found.regions[id];
    r.area += m;
    found.moment[id] += centre * m;
    for (int k = 0; k < piece.n; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        r.box_min[axis] = std::min(r.box_min[axis], piece.p[k][axis]);
        r.box_max[axis] = std::max(r.box_max[axis], piece.p[k][axis]);
      }
    }
  });
}

// The regions into out, largest area first (ties: lowest face id first),
// their ids in out->face_region renumbered to match.
void RankRegions(const RegionsFound& found, ThinSurface* out) {
  const std::vector<ThinRegion>& regions = found.regions;
  std::vector<int32_t> order(regions.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
    if (regions[a].area != regions[b].area) {
      return regions[a].area > regions[b].area;
    }
    return found.first_face[a] < found.first_face[b];
  });
  std::vector<int32_t> rank(regions.size());
  for (size_t i = 0; i < order.size(); ++i) {
    rank[order[i]] = static_cast<int32_t>(i);
    out->regions.push_back(regions[order[i]]);
    out->thin_area += regions[order[i]].area;
  }
  for (int32_t& id : out->face_region) {
    if (id >= 0) id = rank[id];
  }
}

}  // namespace

absl::StatusOr<ThinSurface> FindThinRegions(const Mesh& mesh,
                                            const std::vector<double>& values,
                                            const ThinRegionParams& params) {
  if (absl::Status s = CheckThinParams(params); !s.ok()) return s;
  if (absl::Status s = CheckValues(mesh, values, params.samples); !s.ok()) {
    return s;
  }
  const Field field{values, params.samples == SampleSet::kFaces};
  const double t_min = params.t_min;
  const int32_t nf = static_cast<int32_t>(mesh.num_faces());
  ThinSurface out;
  out.t_min = t_min;
  out.min_thickness = kNaN;
  out.face_region.assign(nf, -1);
  const FaceFlags flags = FlagFaces(mesh, field, t_min);
  ForEachElement(mesh, [&](int64_t f, const Element& e) {
    out.total_area += e.measure;
    if (!flags.valued[f]) out.missing_area += e.measure;
  });
  FindMinimum(mesh, field, &out);
  std::vector<int32_t> parent(nf);
  std::iota(parent.begin(), parent.end(), 0);
  JoinThinFaces(mesh, field, flags.thin, t_min, parent);
  RegionsFound found =
      GroupThinFaces(mesh, field, flags.thin, parent, out.face_region);
  MeasureParts(mesh, field, t_min, out.face_region, found);
  for (size_t i = 0; i < found.regions.size(); ++i) {
    ThinRegion& r = found.regions[i];
    r.min_point = r.min_face >= 0 ? FaceCentroid(mesh, r.min_face)
                                  : mesh.positions[r.min_vertex];
    r.centroid = r.area > 0 ? found.moment[i] / r.area : r.min_point;
    r.speck = r.area < params.min_region_area;
  }
  RankRegions(found, &out);
  return out;
}

absl::StatusOr<AreaHistogram> ThicknessAreaHistogram(
    const Mesh& mesh, const std::vector<double>& values, double lo, double hi,
    int bins, SampleSet samples) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
    return absl::InvalidArgumentError(
        absl::StrCat("histogram range [", lo, ", ", hi, "] is empty"));
  }
  if (bins < 1 || bins > 10000) {
    return absl::InvalidArgumentError(
        absl::StrCat("bins must be in 1..10000, got ", bins));
  }
  if (absl::Status s = CheckValues(mesh, values, samples); !s.ok()) return s;
  const Field field{values, samples == SampleSet::kFaces};
  AreaHistogram h{lo, hi, std::vector<double>(bins, 0.0)};
  auto bin_of = [&](double t) {
    // Clamped in double: far outside [lo, hi] the product overflows int.
    const double x = std::clamp((t - lo) / (hi - lo) * bins, 0.0,
                                static_cast<double>(bins - 1));
    return static_cast<int>(x);
  };
  // The bins' inner edges; the outer ones are open (clamping).
  auto edge = [&](int k) {
    if (k <= 0) return -kInf;
    if (k >= bins) return kInf;
    return lo + (hi - lo) * k / bins;
  };
  ForEachElement(mesh, [&](int64_t f, const Element& e) {
    if (!HasValues(mesh, field, f)) return;
    const Corners c = CornersOf(mesh, field, f, e);
    const double* v = c.v.data();
    const int k0 = bin_of(*std::min_element(v, v + e.n));
    const int k1 = bin_of(*std::max_element(v, v + e.n));
    double below = 0;
    for (int k = k0; k <= k1; ++k) {
      const double next =
          k == k1 ? e.measure : MeasureBelow(e.measure, v, e.n, edge(k + 1));
      h.area[k] += next - below;
      below = next;
    }
  });
  return h;
}

}  // namespace meshgauge
