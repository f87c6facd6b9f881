// Wavefront OBJ: `v` vertices (extra numbers such as w or colours are
// ignored; they must be numbers, NaN allowed), `f` faces and `l` polylines (2D
// curves; a statement may continue on the next line after a backslash), `g ID`
// with an integer ID sets the region of what follows. Every other statement
// (vt, vn, mtllib, usemtl, o, s, ...) is ignored: no side file is opened.
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge::io {
namespace {

// The vertex part of `i`, `i/t`, `i//n`, `i/t/n`; 1-based, negative
// relative to the vertices defined so far. The texture and normal parts
// are not used; they may be empty (`1//`, `2/2/`, as some exporters write)
// but when present must be indices too (`1/x` is malformed).
bool ParseObjIndex(absl::string_view token, int64_t defined, int64_t* out) {
  const std::vector<absl::string_view> parts = absl::StrSplit(token, '/');
  int64_t i = 0, unused = 0;
  if (parts.size() > 3 || !ParseInt64(parts[0], &i) || i == 0) return false;
  for (size_t k = 1; k < parts.size(); ++k) {
    if (!parts[k].empty() && !ParseInt64(parts[k], &unused)) return false;
  }
  *out = i > 0 ? i - 1 : defined + i;
  return true;
}

// 2 when the file has only polylines (`l`), else 3: a first pass, so that
// faces are built for the right dimension. Errors: InvalidArgument for a
// file with both.
absl::StatusOr<int> Dimension(absl::string_view text, const std::string& path) {
  bool has_f = false, has_l = false;
  TokenScanner scan(text, '#', /*continuation=*/true);
  absl::string_view tok;
  while (scan.Next(&tok)) {
    has_f |= tok == "f";
    has_l |= tok == "l";
    scan.SkipLine();
  }
  if (has_f && has_l) {
    return absl::InvalidArgumentError(
        absl::StrCat(path,
                     ": mixes faces (f) and polylines (l); a mesh is either 3D "
                     "faces or a 2D curve"));
  }
  return has_l ? 2 : 3;
}

// The rest of a `v` statement on `line`: 3 coordinates, then up to 4
// numbers (w or a colour) that are not used.
absl::Status ReadVertex(TokenScanner& scan, const std::string& path,
                        int64_t line, int dimension, MeshBuilder& builder) {
  absl::string_view tok;
  double xyz[3];
  int count = 0;
  while (scan.NextOnLine(&tok)) {
    double value;
    // w or a colour, not used: any number (a NaN colour is no coordinate).
    if (count >= 3 && absl::SimpleAtod(tok, &value)) {
      ++count;
      continue;
    }
    if (!ParseDouble(tok, &value)) {
      return LineError(
          path, line,
          absl::StrCat("vertex ", builder.num_vertices(), ": ", Quote(tok),
                       count < 3 ? " is not a finite number"
                                 : " (w or a colour) is not a number"));
    }
    if (count < 3) xyz[count] = value;
    ++count;
  }
  if (dimension == 2 && count >= 3 && xyz[2] != 0) {
    return LineError(
        path, line,
        absl::StrCat("vertex ", builder.num_vertices(), " has z = ", xyz[2],
                     ", but the file has polylines (l) and no faces (f): "
                     "meshgauge reads those as a 2D curve in the plane "
                     "z = 0 (3D curves have no thickness to measure)"));
  }
  if (count < 3 || count > 7) {
    return LineError(
        path, line,
        absl::StrCat("vertex ", builder.num_vertices(), " has ", count,
                     " numbers (3 coordinates, optionally w "
                     "or a colour)"));
  }
  return builder.AddVertex({xyz[0], xyz[1], xyz[2]});
}

// The rest of an `f` or `l` (`polyline`) statement on `line`: its vertex
// indices, a face or a polyline's segments in `region`.
absl::Status ReadFaceOrPolyline(TokenScanner& scan, const std::string& path,
                                int64_t line, bool polyline, int32_t region,
                                std::vector<int64_t>& corners,
                                MeshBuilder& builder) {
  absl::string_view tok;
  corners.clear();
  while (scan.NextOnLine(&tok)) {
    int64_t index;
    if (!ParseObjIndex(tok, builder.num_vertices(), &index)) {
      return LineError(path, line,
                       absl::StrCat(Quote(tok), " is not a vertex index"));
    }
    if (index < 0 || index >= builder.num_vertices()) {
      return LineError(
          path, line,
          absl::StrCat("vertex index ", Quote(tok),
                       " is out of range: ", builder.num_vertices(),
                       " vertices are defined before this line (OBJ "
                       "indices start at 1; negative ones count back)"));
    }
    corners.push_back(index);
  }
  const auto where = AtLine(line);
  if (!polyline) return builder.AddFace(corners, region, where);
  if (corners.size() < 2) {
    return LineError(path, line, "a polyline needs at least 2 vertices");
  }
  for (size_t k = 0; k + 1 < corners.size(); ++k) {
    const int64_t seg[2] = {corners[k], corners[k + 1]};
    if (absl::Status s = builder.AddFace(seg, region, where); !s.ok()) return s;
  }
  return absl::OkStatus();
}

// The rest of a `g` statement: its region, an integer ID (0 for a name).
int32_t ReadRegion(TokenScanner& scan) {
  absl::string_view name;
  int64_t id = 0;
  const int32_t region = scan.NextOnLine(&name) && ParseInt64(name, &id) &&
                                 id >= INT32_MIN && id <= INT32_MAX
                             ? static_cast<int32_t>(id)
                             : 0;
  scan.SkipLine();
  return region;
}

}  // namespace

absl::StatusOr<MeshFile> ParseObj(absl::string_view text,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  if (absl::Status s = CheckLineEnds(path, text); !s.ok()) return s;
  auto dimension = Dimension(text, path);
  if (!dimension.ok()) return dimension.status();
  MeshBuilder builder(path, *dimension, &limits);
  TokenScanner scan(text, '#', /*continuation=*/true);
  absl::string_view tok;
  std::vector<int64_t> corners;
  int32_t region = 0;
  while (scan.Next(&tok)) {
    const int64_t line = scan.line();
    absl::Status s;
    if (tok == "v") {
      s = ReadVertex(scan, path, line, *dimension, builder);
    } else if (tok == "f" || tok == "l") {
      s = ReadFaceOrPolyline(scan, path, line, tok == "l", region, corners,
                             builder);
    } else if (tok == "g") {
      region = ReadRegion(scan);
    } else {
      scan.SkipLine();
    }
    if (!s.ok()) return s;
  }
  if (builder.num_faces() == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": no faces (f) or polylines (l)"));
  }
  return builder.Finish(*dimension == 2 ? "obj (2D polylines)" : "obj");
}

}  // namespace meshgauge::io
