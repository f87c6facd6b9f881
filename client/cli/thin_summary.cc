#include "client/cli/thin_summary.h"

#include "absl/strings/str_format.h"

namespace meshgauge::cli {
namespace {

nlohmann::json Point(const Vec3& p) { return {p.x, p.y, p.z}; }

double Share(double part, double whole) { return whole > 0 ? part / whole : 0; }

}  // namespace

std::string Percent(double share) {
  std::string text;
  for (int digits = 3; digits <= 17; ++digits) {
    text = absl::StrFormat("%.*g", digits, 100 * share);
    if (share >= 1 || text != "100") break;
  }
  return text;
}

std::string ThinSentence(const ThinSurface& thin, bool curve) {
  const char* surface = curve ? "curve" : "surface";
  const char* measure = curve ? "length" : "area";
  if (thin.min_vertex < 0) {
    return absl::StrFormat("no %s of the %s has a value",
                           thin.min_face >= 0 ? "face" : "vertex", surface);
  }
  std::string s = absl::StrFormat(
      "%s %% of the %s (%s %.4g of %.4g) is thinner than %g; thinnest %.4g "
      "at (%.6g, %.6g, %.6g)",
      Percent(Share(thin.thin_area, thin.total_area)), surface, measure,
      thin.thin_area, thin.total_area, thin.t_min, thin.min_thickness,
      thin.min_point.x, thin.min_point.y, thin.min_point.z);
  if (thin.missing_area > 0) {
    s += absl::StrFormat("; %s %% has no value",
                         Percent(Share(thin.missing_area, thin.total_area)));
  }
  return s;
}

nlohmann::json ThinJson(const ThinSurface& thin) {
  nlohmann::json j;
  j["t_min"] = thin.t_min;
  j["total_area"] = thin.total_area;
  j["thin_area"] = thin.thin_area;
  j["missing_area"] = thin.missing_area;
  j["thin_fraction"] = Share(thin.thin_area, thin.total_area);
  if (thin.min_vertex >= 0) {
    j["thinnest"] = {{"value", thin.min_thickness},
                     {"vertex", thin.min_vertex},
                     {"point", Point(thin.min_point)}};
    if (thin.min_face >= 0) j["thinnest"]["face"] = thin.min_face;
  } else {
    j["thinnest"] = nullptr;
  }
  j["regions"] = nlohmann::json::array();
  for (const ThinRegion& r : thin.regions) {
    j["regions"].push_back({{"faces", r.faces},
                            {"area", r.area},
                            {"min_thickness", r.min_thickness},
                            {"min_vertex", r.min_vertex},
                            {"min_point", Point(r.min_point)},
                            {"centroid", Point(r.centroid)},
                            {"box_min", Point(r.box_min)},
                            {"box_max", Point(r.box_max)},
                            {"speck", r.speck}});
    if (r.min_face >= 0) j["regions"].back()["min_face"] = r.min_face;
  }
  return j;
}

}  // namespace meshgauge::cli
