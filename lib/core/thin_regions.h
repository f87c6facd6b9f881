// Where a surface is thinner than a minimum thickness, and how much of it:
// thin regions, the surface measure per thickness band, the thinnest spot.
//
// Thickness on a face is the linear interpolation of its vertices' values
// (quads as the two triangles (0,1,2), (0,2,3) of the ray pass; segments in
// 2D), or with face samples (SPEC v2 §5c) the face's own value, constant on
// it. A face with a vertex without a value (NaN), or without a value of its
// own, has no thickness: it is counted as missing, never as thin. "Area" is the face measure: area in 3D
// (mesh units squared), length in 2D (mesh units).
#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

struct ThinRegionParams {
  double t_min = 0;  // mesh units, > 0 and finite.
  // Regions whose thin area is below this are specks (still listed), >= 0.
  double min_region_area = 0;
  // Where the values are: #V vertex values, or #F face values.
  SampleSet samples = SampleSet::kVertices;
};

// A connected set of faces whose interpolated thickness falls below t_min
// (faces joined by an edge whose own interpolation falls below it; in 2D by
// a vertex whose value does; face values: thin faces sharing an edge, in 2D
// a vertex).
struct ThinRegion {
  int64_t faces = 0;
  double area = 0;  // measure of the part below t_min.
  double min_thickness = 0;
  int32_t min_vertex = -1;  // where: the vertex of that value (lowest id).
  // Face values: the face of that value (lowest id; min_vertex is its
  // first corner, min_point its centroid); -1 for vertex values.
  int32_t min_face = -1;
  Vec3 min_point;
  Vec3 centroid;          // of the part below t_min (measure-weighted).
  Vec3 box_min, box_max;  // axis-aligned box of the part below t_min.
  bool speck = false;     // area < min_region_area.
};

struct ThinSurface {
  double t_min = 0;
  double total_area = 0;    // every face.
  double missing_area = 0;  // faces with a vertex without a value.
  double thin_area = 0;     // sum of the regions' areas.
  // The smallest value of any vertex (NaN and -1 when no vertex has one;
  // ties: the lowest vertex id); face values: of any face, as in
  // ThinRegion.
  double min_thickness = 0;
  int32_t min_vertex = -1;
  int32_t min_face = -1;
  Vec3 min_point;
  // By area, largest first (ties: the region holding the lower face id).
  std::vector<ThinRegion> regions;
  // #F: the index in `regions` of each face, -1 when the face is not thin.
  std::vector<int32_t> face_region;
};

// values: #V (#F with params.samples kFaces), NaN where there is no value.
// Precondition: mesh validated.
// Errors: InvalidArgument for a bad t_min or min_region_area, or a values
// array of another size. O(F log F).
absl::StatusOr<ThinSurface> FindThinRegions(const Mesh& mesh,
                                            const std::vector<double>& values,
                                            const ThinRegionParams& params);

// Surface measure whose interpolated thickness lies in each of `bins` equal
// bins of [lo, hi] (values outside are clamped into the end bins); exact for
// the linear interpolation. Faces without values are left out.
struct AreaHistogram {
  double lo = 0, hi = 0;
  std::vector<double> area;  // per bin.
};
// Errors: InvalidArgument unless lo < hi (finite), 1 <= bins <= 10000 and
// values has #V entries (#F for face samples).
absl::StatusOr<AreaHistogram> ThicknessAreaHistogram(
    const Mesh& mesh, const std::vector<double>& values, double lo, double hi,
    int bins, SampleSet samples = SampleSet::kVertices);

// The measure of the part of a triangle of area `area` with vertex values
// a, b, c (any order) whose linear interpolation is below s. Exact formula.
double TriangleAreaBelow(double area, double a, double b, double c, double s);

}  // namespace meshgauge
