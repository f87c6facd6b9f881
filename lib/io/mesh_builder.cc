#include "lib/io/mesh_builder.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "lib/core/polygon.h"

namespace meshgauge::io {
namespace {

constexpr int64_t kReserveStep = int64_t{1} << 20;

}  // namespace

int64_t MeshBuilder::BytesHeld() const {
  return static_cast<int64_t>(
      file_.mesh.positions.capacity() * sizeof(Vec3) +
      (sizes_.capacity() + corners_.capacity() + regions_.capacity()) *
          sizeof(int32_t) +
      polygon_places_.capacity() * sizeof(polygon_places_[0]) +
      file_.mesh.faces.capacity() * sizeof(Face) +
      file_.mesh.face_regions.capacity() * sizeof(int32_t));
}

absl::Status CheckReadCancelled(const ReadLimits* limits,
                                const std::string& path) {
  if (limits == nullptr || !limits->cancelled || !limits->cancelled()) {
    return absl::OkStatus();
  }
  return absl::CancelledError(absl::StrCat(path, ": reading cancelled"));
}

absl::Status CheckReadCounts(const ReadLimits* limits, const std::string& path,
                             int64_t vertices, int64_t faces) {
  if (limits == nullptr) return absl::OkStatus();
  if (vertices > limits->max_vertices) {
    return absl::ResourceExhaustedError(
        absl::StrCat(path, ": more than the limit of ", limits->max_vertices,
                     " vertices (max_vertices)"));
  }
  if (faces > limits->max_faces) {
    return absl::ResourceExhaustedError(
        absl::StrCat(path, ": more than the limit of ", limits->max_faces,
                     " faces (max_faces; polygons count their triangles)"));
  }
  return CheckReadCancelled(limits, path);
}

absl::Status MeshBuilder::CheckLimits(int64_t vertices, int64_t faces,
                                      int64_t extra) {
  if (limits_ == nullptr) return absl::OkStatus();
  if (absl::Status s = CheckReadCounts(limits_, path_, vertices, faces);
      !s.ok()) {
    return s;
  }
  // Room for the arrays to double before the next report.
  const int64_t bytes = 2 * BytesHeld() + extra_bytes_ + extra;
  if (limits_->reserve && bytes > reported_bytes_) {
    reported_bytes_ = bytes + kReserveStep;
    return limits_->reserve(reported_bytes_);
  }
  return absl::OkStatus();
}

absl::Status MeshBuilder::ReservePositions(int64_t n) {
  if (absl::Status s =
          CheckLimits(n, triangles_, n * static_cast<int64_t>(sizeof(Vec3)));
      !s.ok()) {
    return s;
  }
  file_.mesh.positions.reserve(n);
  return absl::OkStatus();
}

absl::Status MeshBuilder::ReserveFaces(int64_t n, int corners) {
  const int64_t bytes =
      n * static_cast<int64_t>((2 + corners) * sizeof(int32_t) + sizeof(Face));
  if (absl::Status s = CheckLimits(num_vertices(), triangles_ + n, bytes);
      !s.ok()) {
    return s;
  }
  // A declared count passed the file-size check at a byte or so a face;
  // beyond 2^24 faces the arrays grow as faces arrive (a crafted header
  // cannot make the reader reserve gigabytes).
  const int64_t room = std::min<int64_t>(n, int64_t{1} << 24);
  sizes_.reserve(room);
  corners_.reserve(room * corners);
  regions_.reserve(room);
  return absl::OkStatus();
}

absl::Status MeshBuilder::AddFace(absl::Span<const int64_t> corners,
                                  int32_t region,
                                  absl::FunctionRef<std::string()> where) {
  const int64_t n = std::ssize(corners);
  const int64_t min = file_.mesh.dimension == 2 ? 2 : 3;
  if (n < min || (file_.mesh.dimension == 2 && n != 2)) {
    return absl::InvalidArgumentError(absl::StrCat(
        path_, ": ", where(), ": face ", num_faces(), " has ", n, " corners (",
        file_.mesh.dimension == 2 ? "2" : "at least 3", " needed)"));
  }
  if (n > kMaxPolygonCorners) {
    return absl::InvalidArgumentError(
        absl::StrCat(path_, ": ", where(), ": face ", num_faces(), " has ", n,
                     " corners (at most ", kMaxPolygonCorners, ")"));
  }
  for (int64_t c : corners) {
    if (c < 0 || c >= num_vertices()) {
      return absl::InvalidArgumentError(absl::StrCat(
          path_, ": ", where(), ": face ", num_faces(), " refers to vertex ", c,
          " but ", num_vertices(), " vertices are defined"));
    }
  }
  if (n > 4) {
    std::vector<int64_t> sorted(corners.begin(), corners.end());
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(path_, ": ", where(), ": polygon face ", num_faces(),
                       " repeats a vertex"));
    }
    polygon_places_.emplace_back(num_faces(), where());
  }
  triangles_ += n > 4 ? n - 2 : 1;
  // Checked when an array is about to grow, and every 65,536 faces: never
  // per face, as cancelled() may be a call into the transport (the
  // server's IsCancelled).
  if (limits_ != nullptr &&
      (sizes_.size() == sizes_.capacity() ||
       corners_.size() + n > corners_.capacity() ||
       (n > 4 && polygon_places_.size() == polygon_places_.capacity()) ||
       sizes_.size() % 65536 == 0)) {
    if (absl::Status s = CheckLimits(num_vertices(), triangles_, 0); !s.ok()) {
      return s;
    }
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
  const int64_t regions = any_region_ ? triangles_ : 0;
  if (absl::Status s =
          CheckLimits(num_vertices(), triangles_,
                      triangles_ * static_cast<int64_t>(sizeof(Face)) +
                          regions * static_cast<int64_t>(sizeof(int32_t)));
      !s.ok()) {
    return s;
  }
  mesh.faces.reserve(triangles_);
  mesh.face_regions.reserve(regions);
  int64_t fallback_work = 0;
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
      if (absl::Status s = CheckReadCancelled(limits_, path_); !s.ok()) {
        return s;
      }
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
        fallback_work += int64_t{n} * n * n;
        if (limits_ && fallback_work > limits_->max_fallback_work) {
          return absl::ResourceExhaustedError(absl::StrCat(
              path_,
              ": the polygons that are not simple in their plane need "
              "more than ",
              limits_->max_fallback_work,
              " units (corners³ summed) to triangulate; triangulate them "
              "before sending"));
        }
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
