// The interactive view of index.html (`meshgauge report`): three.js, bundled
// by scripts/install_web_deps.sh and embedded at build time
// (web/embed.cmake), the page's script web/report_viewer.js, and the data it
// reads: the mesh, its values and the thin regions. See docs/report.md.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge::cli {

namespace web {
extern const std::string_view kThreeBundle;   // web/vendor/three.bundle.min.js
extern const std::string_view kThreeLicence;  // web/vendor/three.LICENSE
extern const std::string_view kViewerScript;  // web/report_viewer.js
extern const std::string_view kViewerMarkup;  // web/report_viewer.html
}  // namespace web

// Above this many vertices the page sends a simplified copy: vertices
// merged on a grid down to at most this many, positions quantised to 16 bits
// per axis and values sent as 32-bit floats. At or below it, the mesh is
// sent whole in doubles, so the page's live numbers equal the CLI's.
inline constexpr int64_t kMaxShownVertices = 200000;

// The JSON the page's script reads: t_min, colour range, regions (from
// `report`, report.json's object) and the mesh (its faces as triangles
// (0,1,2), (0,2,3), or 2D segments) with its values (per vertex, or per
// triangle for face samples), base64 little-endian.
nlohmann::json ViewerData(const Mesh& mesh, const std::vector<double>& values,
                          SampleSet samples, const nlohmann::json& report,
                          int64_t max_vertices = kMaxShownVertices);

// The scripts that end the page: three.js, the data, the page's script.
std::string ViewerScripts(const nlohmann::json& data);

}  // namespace meshgauge::cli
