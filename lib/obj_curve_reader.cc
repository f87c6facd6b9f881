#include "lib/obj_curve_reader.h"

#include <fstream>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace meshgauge {
namespace {

absl::Status LineError(const std::string& path, int64_t line_no,
                       absl::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat("'", path, "' line ", line_no, ": ", what));
}

}  // namespace

absl::StatusOr<std::optional<Mesh>> ReadObjCurveIfAny(const std::string& path) {
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open '", path, "'"));
  Mesh mesh;
  mesh.dimension = 2;
  bool has_lines = false;
  int64_t face_lines = 0;
  int32_t region = 0;
  std::string line;
  int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::vector<absl::string_view> tok =
        absl::StrSplit(line, absl::ByAnyChar(" \t\r"), absl::SkipEmpty());
    if (tok.empty()) continue;
    if (tok[0] == "f") {
      ++face_lines;
    } else if (tok[0] == "g" || tok[0] == "o") {
      // `g 3` puts the following polylines in region 3; names are ignored.
      int32_t id = 0;
      if (tok.size() >= 2 && absl::SimpleAtoi(tok[1], &id)) region = id;
    } else if (tok[0] == "v") {
      if (tok.size() < 3) return LineError(path, line_no, "vertex needs x y");
      double c[3] = {0, 0, 0};
      for (size_t i = 1; i < tok.size() && i <= 3; ++i) {
        if (!absl::SimpleAtod(tok[i], &c[i - 1])) {
          return LineError(path, line_no, "bad vertex coordinate");
        }
      }
      mesh.positions.push_back({c[0], c[1], c[2]});
    } else if (tok[0] == "l") {
      has_lines = true;
      if (tok.size() < 3) {
        return LineError(path, line_no, "a polyline needs at least 2 vertices");
      }
      std::vector<int32_t> ids;
      for (size_t i = 1; i < tok.size(); ++i) {
        int64_t id = 0;
        const absl::string_view ref = tok[i].substr(0, tok[i].find('/'));
        if (!absl::SimpleAtoi(ref, &id) || id == 0) {
          return LineError(path, line_no, "bad vertex reference");
        }
        // Negative: relative to the vertices read so far. Range is checked
        // by ValidateMesh.
        id = id > 0 ? id - 1 : std::ssize(mesh.positions) + id;
        ids.push_back(static_cast<int32_t>(
            std::clamp<int64_t>(id, -1, std::numeric_limits<int32_t>::max())));
      }
      for (size_t i = 0; i + 1 < ids.size(); ++i) {
        mesh.faces.push_back(Face::Segment(ids[i], ids[i + 1]));
        mesh.face_regions.push_back(region);
      }
    }
  }
  if (!has_lines) return std::optional<Mesh>();
  if (face_lines > 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path, "' mixes ", face_lines,
                     " faces (f) with polylines (l): mixed dimensions"));
  }
  return std::optional<Mesh>(std::move(mesh));
}

}  // namespace meshgauge
