#include "client/cli/report_viewer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"

namespace meshgauge::cli {
namespace {

constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();

template <typename T>
nlohmann::json PackedArray(const std::vector<T>& v, const char* dtype) {
  std::string bytes(v.size() * sizeof(T), '\0');
  if (!v.empty()) std::memcpy(bytes.data(), v.data(), bytes.size());
  return {{"dtype", dtype}, {"b64", absl::Base64Escape(bytes)}};
}

// What the page shows: positions, values (per vertex, or per element for
// face samples) and elements (triangles or segments, `arity` corners each).
struct PageMesh {
  std::vector<Vec3> positions;
  std::vector<double> values;
  std::vector<uint32_t> elements;
  int arity = 3;
};

PageMesh PageElements(const Mesh& mesh, const std::vector<double>& values,
               bool faces) {
  PageMesh s;
  s.positions = mesh.positions;
  s.arity = mesh.dimension == 2 ? 2 : 3;
  if (!faces) s.values = values;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& face = mesh.faces[f];
    if (face.size == 2) {
      s.elements.insert(s.elements.end(), {uint32_t(face.v[0]), uint32_t(face.v[1])});
      if (faces) s.values.push_back(values[f]);
      continue;
    }
    for (int t = 0; t + 2 < face.size; ++t) {  // as ForEachElement splits.
      s.elements.insert(s.elements.end(), {uint32_t(face.v[0]),
                                           uint32_t(face.v[t + 1]),
                                           uint32_t(face.v[t + 2])});
      if (faces) s.values.push_back(values[f]);
    }
  }
  return s;
}

// Vertex clustering: vertices in one cell of a grid become one, at their
// mean position with the mean of their values (NaN when none has one);
// elements with two corners in one cell go. The cell grows until at most
// `max_vertices` cells are occupied.
PageMesh Simplified(const PageMesh& in, bool faces, int64_t max_vertices) {
  Vec3 lo = in.positions[0], hi = in.positions[0];
  for (const Vec3& p : in.positions) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  const double diag = std::max(Norm(hi - lo), 1e-300);
  double cell = diag / std::sqrt(double(max_vertices));
  std::vector<int32_t> cell_of(in.positions.size());
  int64_t cells = 0;
  for (int round = 0; round < 40; ++round) {
    std::unordered_map<uint64_t, int32_t> ids;
    ids.reserve(in.positions.size());
    for (size_t i = 0; i < in.positions.size(); ++i) {
      uint64_t key = 0;
      for (int a = 0; a < 3; ++a) {
        key = key * 2097152 + uint64_t((in.positions[i][a] - lo[a]) / cell);
      }
      cell_of[i] = ids.try_emplace(key, int32_t(ids.size())).first->second;
    }
    cells = std::ssize(ids);
    if (cells <= max_vertices) break;
    cell *= std::max(1.02, std::sqrt(double(cells) / max_vertices));
  }
  PageMesh out;
  out.arity = in.arity;
  out.positions.assign(cells, Vec3());
  std::vector<double> members(cells, 0), sum(cells, 0), valued(cells, 0);
  for (size_t i = 0; i < in.positions.size(); ++i) {
    out.positions[cell_of[i]] += in.positions[i];
    members[cell_of[i]] += 1;
    if (!faces && !std::isnan(in.values[i])) {
      sum[cell_of[i]] += in.values[i];
      valued[cell_of[i]] += 1;
    }
  }
  for (int64_t c = 0; c < cells; ++c) {
    out.positions[c] = out.positions[c] / std::max(members[c], 1.0);
    if (!faces) out.values.push_back(valued[c] > 0 ? sum[c] / valued[c] : kNoValue);
  }
  const size_t n = in.arity;
  for (size_t e = 0; e * n < in.elements.size(); ++e) {
    uint32_t c[3];
    bool distinct = true;
    for (size_t k = 0; k < n; ++k) {
      c[k] = cell_of[in.elements[e * n + k]];
      for (size_t j = 0; j < k; ++j) distinct &= c[j] != c[k];
    }
    if (!distinct) continue;
    out.elements.insert(out.elements.end(), c, c + n);
    if (faces) out.values.push_back(in.values[e]);
  }
  return out;
}

nlohmann::json PagePositions(const std::vector<Vec3>& p, bool quantised) {
  if (!quantised) {
    std::vector<double> flat;
    flat.reserve(3 * p.size());
    for (const Vec3& x : p) flat.insert(flat.end(), {x.x, x.y, x.z});
    return PackedArray(flat, "f64");
  }
  Vec3 lo = p.empty() ? Vec3() : p[0], hi = lo;
  for (const Vec3& x : p) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], x[a]);
      hi[a] = std::max(hi[a], x[a]);
    }
  }
  std::vector<uint16_t> q;
  q.reserve(3 * p.size());
  for (const Vec3& x : p) {
    for (int a = 0; a < 3; ++a) {
      const double s = hi[a] > lo[a] ? (x[a] - lo[a]) / (hi[a] - lo[a]) : 0;
      q.push_back(uint16_t(std::lround(std::clamp(s, 0.0, 1.0) * 65535)));
    }
  }
  nlohmann::json j = PackedArray(q, "u16");
  j["box_min"] = {lo.x, lo.y, lo.z};
  j["box_max"] = {hi.x, hi.y, hi.z};
  return j;
}

}  // namespace

nlohmann::json ViewerData(const Mesh& mesh, const std::vector<double>& values,
                          SampleSet samples, const nlohmann::json& report,
                          int64_t max_vertices) {
  const bool faces = samples == SampleSet::kFaces;
  PageMesh shown = PageElements(mesh, values, faces);
  const bool simplify = mesh.num_vertices() > max_vertices;
  if (simplify) shown = Simplified(shown, faces, max_vertices);
  nlohmann::json regions = nlohmann::json::array();
  for (const nlohmann::json& r : report["thin"]["regions"]) {
    regions.push_back({{"centroid", r["centroid"]},
                       {"box_min", r["box_min"]},
                       {"box_max", r["box_max"]}});
  }
  const nlohmann::json& range = report["color_range"];
  nlohmann::json j = {
      {"format", 1},
      {"t_min", report["thin"]["t_min"]},
      {"curve", mesh.dimension == 2},
      {"samples", faces ? "faces" : "vertices"},
      {"up", report["parameters"]["up"]},
      {"color_range",
       {{"low", range["low"]},
        {"high", range["high"]},
        {"source", range["source"]},
        {"above_color", range["above_color"]}}},
      {"regions", regions},
      {"mesh", {{"vertices", mesh.num_vertices()}, {"faces", mesh.num_faces()}}},
      {"shown",
       {{"vertices", shown.positions.size()},
        {"elements", shown.elements.size() / shown.arity},
        {"decimated", simplify},
        {"quantised", simplify},
        {"limit", max_vertices}}},
      {"positions", PagePositions(shown.positions, simplify)},
      {"elements", PackedArray(shown.elements, "u32")},
  };
  j["elements"]["arity"] = shown.arity;
  if (simplify) {
    j["values"] = PackedArray(std::vector<float>(shown.values.begin(), shown.values.end()), "f32");
  } else {
    j["values"] = PackedArray(shown.values, "f64");
  }
  return j;
}

std::string ViewerScripts(const nlohmann::json& data) {
  // '<' only occurs in the JSON's strings, where \u003c reads the same: no
  // "</script>" can end the data early.
  const std::string text = absl::StrReplaceAll(
      data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace),
      {{"<", "\\u003c"}});
  return absl::StrCat("<script>\n/* three.js, embedded under its licence:\n",
                      std::string(web::kThreeLicence), "*/\n", std::string(web::kThreeBundle),
                      "\n</script>\n",
                      "<script id=\"mg-data\" type=\"application/json\">",
                      text, "</script>\n<script>\n", std::string(web::kViewerScript),
                      "</script>\n");
}

}  // namespace meshgauge::cli
