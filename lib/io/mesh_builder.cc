#include "lib/io/mesh_builder.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "lib/core/polygon.h"

namespace meshgauge::io {

absl::Status MeshBuilder::AddFace(absl::Span<const int64_t> corners,
                                  int32_t region, const std::string& where) {
  const int64_t n = std::ssize(corners);
  const int64_t min = file_.mesh.dimension == 2 ? 2 : 3;
  if (n < min || (file_.mesh.dimension == 2 && n != 2)) {
    return absl::InvalidArgumentError(absl::StrCat(
        path_, ": ", where, ": face ", num_faces(), " has ", n, " corners (",
        file_.mesh.dimension == 2 ? "2" : "at least 3", " needed)"));
  }
  if (n > kMaxPolygonCorners) {
    return absl::InvalidArgumentError(
        absl::StrCat(path_, ": ", where, ": face ", num_faces(), " has ", n,
                     " corners (at most ", kMaxPolygonCorners, ")"));
  }
  for (int64_t c : corners) {
    if (c < 0 || c >= num_vertices()) {
      return absl::InvalidArgumentError(absl::StrCat(
          path_, ": ", where, ": face ", num_faces(), " refers to vertex ", c,
          " but ", num_vertices(), " vertices are defined"));
    }
  }
  if (n > 4) {
    std::vector<int64_t> sorted(corners.begin(), corners.end());
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path_, ": ", where, ": polygon face ", num_faces(),
                       " repeats a vertex"));
    }
    polygon_places_.emplace_back(num_faces(), where);
  }
  sizes_.push_back(static_cast<int32_t>(n));
  for (int64_t c : corners) corners_.push_back(static_cast<int32_t>(c));
  regions_.push_back(region);
  any_region_ |= region != 0;
  return absl::OkStatus();
}

absl::StatusOr<MeshFile> MeshBuilder::Finish(std::string format) {
  Mesh& mesh = file_.mesh;
  file_.format = std::move(format);
  file_.file_faces = num_faces();
  mesh.faces.reserve(sizes_.size());
  size_t offset = 0, polygon = 0;
  std::vector<Vec3> ring;
  for (size_t f = 0; f < sizes_.size(); ++f) {
    const int32_t* c = corners_.data() + offset;
    const int32_t n = sizes_[f];
    offset += n;
    const size_t before = mesh.faces.size();
    if (n == 2) {
      mesh.faces.push_back(Face::Segment(c[0], c[1]));
    } else if (n == 3) {
      mesh.faces.push_back(Face::Triangle(c[0], c[1], c[2]));
    } else if (n == 4) {
      mesh.faces.push_back(Face::Quad(c[0], c[1], c[2], c[3]));
    } else {
      ring.clear();
      for (int32_t k = 0; k < n; ++k) ring.push_back(mesh.positions[c[k]]);
      bool fallback = false;
      auto tris = TriangulatePolygon(ring, &fallback);
      if (!tris.ok()) {
        const auto& [id, where] = polygon_places_[polygon];
        return absl::InvalidArgumentError(
            absl::StrCat(path_, ": ", where, ": polygon face ", id, " (", n,
                         " corners): ", tris.status().message()));
      }
      for (const auto& t : *tris) {
        mesh.faces.push_back(Face::Triangle(c[t[0]], c[t[1]], c[t[2]]));
      }
      ++polygon;
      ++file_.polygons_triangulated;
      if (fallback) {
        if (file_.polygons_fallback == 0) {
          file_.first_fallback_polygon = polygon_places_[polygon - 1].first;
        }
        ++file_.polygons_fallback;
      }
    }
    if (any_region_) {
      mesh.face_regions.insert(mesh.face_regions.end(),
                               mesh.faces.size() - before, regions_[f]);
    }
  }
  return std::move(file_);
}

}  // namespace meshgauge::io
