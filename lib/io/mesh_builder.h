// Collects what a reader parses and builds the Mesh: faces are checked as
// they arrive (indices in range, no repeat inside a polygon) with the
// location the reader gives, and polygons with more than four corners are
// triangulated (SPEC v2 §1) when the mesh is finished.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "absl/types/span.h"
#include "lib/io/mesh_file.h"

namespace meshgauge::io {

// The limits' (may be null: none) bounds on `vertices` and `faces` (after
// triangulation), then their cancellation, polled. Errors:
// ResourceExhausted naming the limit; Cancelled.
absl::Status CheckReadCounts(const ReadLimits* limits, const std::string& path,
                             int64_t vertices, int64_t faces);
// Cancelled when the limits' cancelled() says so.
absl::Status CheckReadCancelled(const ReadLimits* limits,
                                const std::string& path);

class MeshBuilder {
 public:
  // `limits` (not owned, may be null) must outlive the builder.
  MeshBuilder(std::string path, int dimension,
              const ReadLimits* limits = nullptr)
      : path_(std::move(path)), limits_(limits) {
    file_.mesh.dimension = dimension;
  }
  // Room for `n` vertices (a count a file declares, checked against the
  // file's size). Errors: the limits'.
  absl::Status ReservePositions(int64_t n);
  // Room for `n` faces of `corners` corners each (a declared count, checked
  // against the file's size), so the face arrays do not grow by copies.
  // Errors: the limits'.
  absl::Status ReserveFaces(int64_t n, int corners);
  // Errors: the limits' (checked when the positions grow).
  absl::Status AddVertex(const Vec3& p) {
    if (limits_ != nullptr &&
        file_.mesh.positions.size() == file_.mesh.positions.capacity()) {
      if (absl::Status s = CheckLimits(num_vertices() + 1, triangles_, 0);
          !s.ok()) {
        return s;
      }
    }
    file_.mesh.positions.push_back(p);
    return absl::OkStatus();
  }
  // Bytes a reader holds beside the builder (e.g. a welding map), counted
  // with the builder's own. Errors: the limits'.
  absl::Status SetExtraBytes(int64_t bytes) {
    extra_bytes_ = bytes;
    return CheckLimits(num_vertices(), triangles_, 0);
  }
  int64_t num_vertices() const { return file_.mesh.num_vertices(); }
  // `where()` names the face's place in the file ("line 12", "byte 4096")
  // for errors; it is called only for an error or a polygon (whose place
  // Finish may report), not per face. Corner indices are 0-based. Errors:
  // InvalidArgument for fewer than 2 (segments) or 3 corners, an index out of
  // range [0, #V) or, in a polygon with more than four corners, a repeated
  // index; the limits'.
  absl::Status AddFace(absl::Span<const int64_t> corners, int32_t region,
                       absl::FunctionRef<std::string()> where);
  int64_t num_faces() const { return std::ssize(sizes_); }
  // Triangulates the polygons and returns the mesh (not validated).
  // Errors: InvalidArgument naming the polygon's face id and place; the
  // limits'.
  absl::StatusOr<MeshFile> Finish(std::string format);

 private:
  // The limits' checks of `vertices` and `faces` (after triangulation) and
  // of the bytes held and about to be (`extra`); polls cancellation.
  absl::Status CheckLimits(int64_t vertices, int64_t faces, int64_t extra);
  int64_t BytesHeld() const;

  std::string path_;
  const ReadLimits* limits_;
  int64_t reported_bytes_ = 0;  // last told to limits_->reserve.
  int64_t extra_bytes_ = 0;     // SetExtraBytes.
  int64_t triangles_ = 0;       // faces after triangulation, so far.
  MeshFile file_;
  std::vector<int32_t> sizes_;
  std::vector<int32_t> corners_;
  std::vector<int32_t> regions_;
  bool any_region_ = false;
  // For polygons only (the messages of Finish).
  std::vector<std::pair<int64_t, std::string>> polygon_places_;
};

}  // namespace meshgauge::io
