#include "client/cli/report_page.h"

#include <algorithm>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_replace.h"
#include "client/cli/report_viewer.h"
#include "client/cli/thin_summary.h"

namespace meshgauge::cli {
namespace {

// HTML text of s; control characters (other than tab and newline) are
// dropped.
std::string Escape(std::string s) {
  s.erase(std::remove_if(s.begin(), s.end(),
                         [](char c) {
                           return static_cast<unsigned char>(c) < 0x20 &&
                                  c != '\t' && c != '\n';
                         }),
          s.end());
  return absl::StrReplaceAll(s, {{"&", "&amp;"},
                                 {"<", "&lt;"},
                                 {">", "&gt;"},
                                 {"\"", "&quot;"},
                                 {"'", "&#39;"}});
}

std::string Text(const nlohmann::json& v) {
  if (v.is_string()) return Escape(v.get<std::string>());
  if (v.is_number_float()) return absl::StrFormat("%.6g", v.get<double>());
  return Escape(v.dump());
}

std::string Point(const nlohmann::json& p) {
  return absl::StrFormat("(%.6g, %.6g, %.6g)", p[0].get<double>(),
                         p[1].get<double>(), p[2].get<double>());
}

std::string Picture(const std::string& png, const std::string& alt) {
  return absl::StrCat("<img alt=\"", alt, "\" src=\"data:image/png;base64,",
                      absl::Base64Escape(png), "\">");
}

std::string RegionTable(const nlohmann::json& thin, bool curve) {
  const double total = thin["total_area"].get<double>();
  std::string rows;
  int rank = 0;
  for (const nlohmann::json& r : thin["regions"]) {
    const double area = r["area"].get<double>();
    absl::StrAppendFormat(
        &rows,
        "<tr data-region=\"%d\"%s><td>%d</td><td>%.6g</td><td>%s %%</td><td>%.6g</td>"
        "<td>%s</td><td>%s</td><td>%s &ndash; %s</td><td>%d</td><td>%s</td>"
        "</tr>\n",
        rank, r["speck"].get<bool>() ? " class=\"speck\"" : "", rank + 1,
        area,
        Percent(total > 0 ? area / total : 0.0),
        r["min_thickness"].get<double>(), Point(r["min_point"]),
        Point(r["centroid"]), Point(r["box_min"]), Point(r["box_max"]),
        r["faces"].get<int64_t>(), r["speck"].get<bool>() ? "speck" : "");
    ++rank;
  }
  if (rank == 0) rows = "<tr><td colspan=\"9\">no thin region</td></tr>\n";
  return absl::StrCat(
      "<table><tr><th>#</th><th>", curve ? "length" : "area",
      "</th><th>share</th><th>min</th><th>thinnest at</th><th>centroid</th>"
      "<th>bounding box</th><th>",
      curve ? "segments" : "faces", "</th><th></th></tr>\n", rows,
      "</table>\n");
}

// The range table: the measure (and share of the whole) per band around
// t_min, rows that the page's script updates as t_min moves.
std::string BandTable(const nlohmann::json& bands, bool curve) {
  std::string rows;
  for (const nlohmann::json& b : bands) {
    const std::string name = b["band"].get<std::string>();
    std::string range = "no value";
    if (name == "below") {
      range = absl::StrFormat("t &lt; %.6g", b["hi"].get<double>());
    } else if (name == "within") {
      range = absl::StrFormat("%.6g &le; t &lt; %.6g", b["lo"].get<double>(),
                              b["hi"].get<double>());
    } else if (name == "above") {
      range = absl::StrFormat("t &ge; %.6g", b["lo"].get<double>());
    }
    const char* what = name == "below"    ? "thinner than t_min"
                       : name == "within" ? "within 10 % above t_min"
                       : name == "above"  ? "thicker"
                                          : "without a value";
    absl::StrAppendFormat(
        &rows,
        "<tr data-band=\"%s\"><th>%s</th><td class=\"range\">%s</td>"
        "<td class=\"area\">%.6g</td><td class=\"share\">%s %%</td></tr>\n",
        name, what, range, b["area"].get<double>(),
        Percent(b["share"].get<double>()));
  }
  return absl::StrCat("<table id=\"mg-bands\"><tr><th>band</th><th>thickness</th><th>",
                      curve ? "length" : "area", "</th><th>share</th></tr>\n",
                      rows, "</table>\n");
}

std::string KeyValues(const nlohmann::json& object) {
  std::string rows;
  for (const auto& [key, value] : object.items()) {
    absl::StrAppend(&rows, "<tr><th>", Escape(key), "</th><td>", Text(value),
                    "</td></tr>\n");
  }
  return absl::StrCat("<table class=\"kv\">\n", rows, "</table>\n");
}

// What the views' colours mean: the map's range, where it came from, the
// overflow colour above it, the outline and the grey.
std::string ColourLegend(const nlohmann::json& report) {
  std::string range;
  if (report.contains("color_range")) {
    const nlohmann::json& c = report["color_range"];
    const bool by_default = c["source"] == "default";
    const nlohmann::json& rgb = c["above_color"];
    range = absl::StrFormat(
        "Colours from %.6g (dark violet) to %.6g (light yellow), %s; "
        "<span style=\"background:#%02x%02x%02x;padding:0 .3em\">%s</span> "
        "above %.6g%s. ",
        c["low"].get<double>(), c["high"].get<double>(),
        by_default ? "0 to 2&middot;t_min by default" : "set by --color-range",
        rgb[0].get<int>(), rgb[1].get<int>(), rgb[2].get<int>(),
        by_default ? "&gt; 2&middot;t_min" : "&gt; " + Text(c["high"]),
        c["high"].get<double>(),
        absl::StrFormat(" (%s %% of the surface)",
                        Percent(report["thin"]["total_area"].get<double>() > 0
                                    ? c["above_area"].get<double>() /
                                          report["thin"]["total_area"]
                                              .get<double>()
                                    : 0.0)));
  }
  return range + "Thin regions outlined in red along t = t_min; grey: no value.";
}

}  // namespace

std::string ReportHtml(const nlohmann::json& report,
                       const std::string& views_png,
                       const std::string& histogram_png,
                       const nlohmann::json& viewer_data) {
  const nlohmann::json& summary = report["summary"];
  nlohmann::json missing = {
      {"vertices without a value", summary["missing_vertices"]},
      {"faces skipped", summary["missing_faces"]},
      {"share of the surface", summary["missing_area_fraction"]},
      {"rays that hit nothing (vertices)", summary["no_hit"]},
      {"degenerate normals (vertices)", summary["degenerate_normal"]},
  };
  if (report.contains("missing_cause")) {
    missing["likely cause"] = report["missing_cause"];
  }
  std::string warnings;
  for (const nlohmann::json& w : summary["warnings"]) {
    absl::StrAppend(&warnings, "<li>", Escape(w.get<std::string>()), "</li>\n");
  }
  return absl::StrCat(
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<title>meshgauge report: ",
      Escape(report["mesh"].get<std::string>()),
      "</title>\n<style>\n"
      "body{font-family:sans-serif;margin:1.5em;color:#141414}\n"
      "img{max-width:100%;border:1px solid #ccc}\n"
      "table{border-collapse:collapse;margin:.5em 0}\n"
      "td,th{border:1px solid #ccc;padding:.2em .5em;text-align:right}\n"
      ".kv th{text-align:left}\n.speck{color:#888}\n"
      ".answer{font-size:1.2em;font-weight:bold}\n"
      "</style>\n</head>\n<body>\n<h1>Thickness of ",
      Escape(report["mesh"].get<std::string>()),
      "</h1>\n<p class=\"answer\" id=\"mg-answer\">",
      Escape(report["sentence"].get<std::string>()), "</p>\n",
      std::string(web::kViewerMarkup), "<h2>Thickness bands</h2>\n",
      BandTable(report["bands"], summary["dimension"].get<int>() == 2),
      "<h2>Views</h2>\n<p>", ColourLegend(report), "</p>\n",
      Picture(views_png, "the mesh coloured by thickness"),
      "\n<h2>Histogram</h2>\n",
      Picture(histogram_png, "surface measure per thickness bin"),
      "\n<h2>Thin regions</h2>\n",
      RegionTable(report["thin"], summary["dimension"].get<int>() == 2),
      "<h2>Parameters</h2>\n", KeyValues(report["parameters"]),
      "<h2>SDF summary</h2>\n",
      KeyValues(nlohmann::json{
          {"vertices", summary["vertices"]},
          {"faces", summary["faces"]},
          {"method", summary["method"]},
          {"sdf min", summary["sdf_min"]},
          {"sdf median", summary["sdf_median"]},
          {"sdf max", summary["sdf_max"]},
      }),
      "<h2>Missing values</h2>\n", KeyValues(missing),
      warnings.empty() ? "" : absl::StrCat("<ul>\n", warnings, "</ul>\n"),
      ViewerScripts(viewer_data), "</body>\n</html>\n");
}

}  // namespace meshgauge::cli
