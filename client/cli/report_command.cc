// meshgauge report: where the part is thinner than t_min, as pictures, a
// JSON report, a web page and a coloured PLY.
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/backend.h"
#include "client/cli/commands.h"
#include "client/cli/report_draw.h"
#include "client/cli/report_page.h"
#include "client/cli/report_viewer.h"
#include "client/cli/summary.h"
#include "client/cli/thin_summary.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_values.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/render.h"
#include "lib/io/mesh_io.h"
#include "lib/io/png_file.h"

namespace meshgauge::cli {
namespace {

// The colour map's range and where it came from.
struct ColorRange {
  ColorScale scale;
  std::string source;       // "default" or "--color-range".
  std::string above_label;  // the legend's name of the overflow colour.
};

// [0, 2 t_min] with values above in the overflow colour, so that the map
// shows the answer (t_min in its middle) whatever the thickest part; or
// --color-range LO HI (values above HI in the overflow colour too).
absl::StatusOr<ColorRange> ColorRangeOf(const ReportFlags& flags) {
  if (flags.color_range.size() == 2) {
    const double lo = flags.color_range[0], hi = flags.color_range[1];
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--color-range: LO < HI, both finite, got ", lo, " ", hi));
    }
    return ColorRange{ColorScale{lo, hi, /*overflow=*/true}, "--color-range",
                      absl::StrFormat("> %.4g", hi)};
  }
  return ColorRange{CenteredOnTMin(flags.t_min), "default", "> 2 T_MIN"};
}

// The measure whose interpolated value is above `hi` (faces without values
// left out): the upper of two bins split at hi, exact for the linear
// interpolation as the histogram is. The range [0, 2 hi] (or [2 hi, 0])
// puts the split at hi exactly.
absl::StatusOr<double> MeasureAbove(const Mesh& mesh,
                                    const std::vector<double>& values,
                                    SampleSet samples, double hi) {
  double lo2 = std::min(0.0, 2 * hi), hi2 = std::max(0.0, 2 * hi);
  if (hi == 0) lo2 = -1, hi2 = 1;
  if (!std::isfinite(2 * hi)) {  // near the largest double: nearly at hi.
    const double room = std::numeric_limits<double>::max() - std::abs(hi);
    lo2 = hi - room;
    hi2 = hi + room;
  }
  auto split = ThicknessAreaHistogram(mesh, values, lo2, hi2, 2, samples);
  if (!split.ok()) return split.status();
  return split->area[1];
}

// What the pictures and the coloured PLY show: the mesh with its vertex
// values, or for face samples each face flat, on corners of its own that
// carry its value (faces keep their order, so per-face marks still apply).
struct Shown {
  Mesh mesh;
  std::vector<double> values;
};

Shown ShownMesh(const Mesh& mesh, const std::vector<double>& values,
                SampleSet samples) {
  if (samples != SampleSet::kFaces) return {mesh, values};
  Shown shown;
  shown.mesh.dimension = mesh.dimension;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    Face face = mesh.faces[f];
    for (int k = 0; k < face.size; ++k) {
      shown.mesh.positions.push_back(mesh.positions[face.v[k]]);
      shown.values.push_back(values[f]);
      face.v[k] = static_cast<int32_t>(shown.mesh.positions.size() - 1);
    }
    shown.mesh.faces.push_back(face);
  }
  return shown;
}

// The range table around t_min: the measure below t_min, from t_min up to
// (not including) 1.1 t_min, from there up, and without a value; exact for
// the linear interpolation (face samples: whole faces by their value), each
// with its share of the whole measure (the four sum to it).
nlohmann::json Bands(const Mesh& mesh, const std::vector<double>& values,
                     SampleSet samples, double t_min, double total) {
  const bool faces = samples == SampleSet::kFaces;
  const double edge = t_min * 1.1;
  double below = 0, below_edge = 0, valued = 0, missing = 0;
  auto measure_below = [](const Element& e, const double* v, double s) {
    if (e.n == 3) return TriangleAreaBelow(e.measure, v[0], v[1], v[2], s);
    const double lo = std::min(v[0], v[1]), hi = std::max(v[0], v[1]);
    if (s <= lo) return 0.0;
    if (s >= hi) return e.measure;
    return e.measure * (s - lo) / (hi - lo);
  };
  ForEachElement(mesh, [&](int64_t f, const Element& e) {
    const Face& face = mesh.faces[f];
    bool has = true;
    for (int k = 0; k < face.size; ++k) {
      has &= !std::isnan(values[faces ? f : face.v[k]]);
    }
    if (!has) {
      missing += e.measure;
      return;
    }
    double v[3];
    for (int k = 0; k < e.n; ++k) v[k] = values[faces ? f : e.v[k]];
    valued += e.measure;
    below += measure_below(e, v, t_min);
    below_edge += measure_below(e, v, edge);
  });
  auto row = [&](const char* band, nlohmann::json lo, nlohmann::json hi,
                 double area) {
    return nlohmann::json{{"band", band},
                          {"lo", lo},
                          {"hi", hi},
                          {"area", area},
                          {"share", total > 0 ? area / total : 0.0}};
  };
  return nlohmann::json::array(
      {row("below", nullptr, t_min, below),
       row("within", t_min, edge, below_edge - below),
       row("above", edge, nullptr, valued - below_edge),
       row("no value", nullptr, nullptr, missing)});
}

absl::StatusOr<std::string> WritePicture(const std::string& path,
                                         const Image& image) {
  if (absl::Status s = WritePng(path, image); !s.ok()) return s;
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  if (!in) return absl::InternalError(absl::StrCat("cannot read '", path, "'"));
  return bytes.str();
}

absl::Status WriteText(const std::string& path, const std::string& text) {
  errno = 0;
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) {
    return absl::InternalError(absl::StrCat(
        "cannot write '", path, "': ", errno ? std::strerror(errno) : "error"));
  }
  return absl::OkStatus();
}

// The JSON text of `j`, bytes that are not UTF-8 (a file name in another
// encoding) replaced by U+FFFD.
std::string Dump(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

absl::Status RunReport(const MeshInput& in, const ReportFlags& flags,
                       const BackendFactory& make) {
  ThinRegionParams thin_params{flags.t_min, flags.min_region_area};
  std::error_code ec;
  std::filesystem::create_directories(flags.out, ec);
  if (ec || !std::filesystem::is_directory(flags.out)) {
    return absl::FailedPreconditionError(
        absl::StrCat("--out '", flags.out, "' is not a directory we can make",
                     ec ? ": " + ec.message() : ""));
  }
  Stopwatch watch;
  auto opened = Open(in, make, /*print_warnings=*/false);  // in the summary.
  if (!opened.ok()) return opened.status();
  const Mesh& mesh = opened->mesh();
  auto result = opened->backend->Sdf(opened->params, Derivatives::kNone);
  if (!result.ok()) return result.status();
  const double sdf_seconds = watch.Seconds();
  const std::vector<double>& values = result->values;
  const SampleSet samples = opened->params.samples;
  thin_params.samples = samples;

  auto thin = FindThinRegions(mesh, values, thin_params);
  if (!thin.ok()) return thin.status();
  auto range = ColorRangeOf(flags);
  if (!range.ok()) return range.status();
  const ColorScale* scale = &range->scale;
  auto above = MeasureAbove(mesh, values, samples, scale->hi);
  if (!above.ok()) return above.status();
  auto histogram =
      ThicknessAreaHistogram(mesh, values, scale->lo, scale->hi, flags.bins,
                             samples);
  if (!histogram.ok()) return histogram.status();
  std::vector<int32_t> outline(thin->face_region);
  for (int32_t& r : outline) {
    if (r >= 0 && thin->regions[r].speck) r = -1;
  }
  watch.Restart();
  RenderOptions render;
  render.width = flags.view_size[0];
  render.height = flags.view_size[1];
  render.outline_below = flags.t_min;  // outlines follow t = t_min.
  const Shown shown = ShownMesh(mesh, values, samples);
  auto views = RenderViews(shown.mesh, shown.values, *scale, outline,
                           StandardViews(flags.up == "y" ? 1 : 2), render);
  if (!views.ok()) return views.status();
  const double render_seconds = watch.Seconds();

  const bool curve = mesh.dimension == 2;
  const std::filesystem::path dir(flags.out);
  auto views_png = WritePicture((dir / "views.png").string(),
                                ComposeViews(*views, *scale, flags.t_min,
                                             range->above_label));
  if (!views_png.ok()) return views_png.status();
  auto histogram_png = WritePicture(
      (dir / "histogram.png").string(),
      DrawHistogram(
          *histogram, *scale, flags.t_min,
          thin->total_area > 0 ? thin->thin_area / thin->total_area : 0,
          curve, *above, range->above_label));
  if (!histogram_png.ok()) return histogram_png.status();
  if (absl::Status s =
          WriteQualityPly((dir / "colored.ply").string(), shown.mesh,
                          shown.values, ColorsOf(*scale, shown.values));
      !s.ok()) {
    return s;
  }

  const std::string sentence = ThinSentence(*thin, curve);
  nlohmann::json report;
  report["mesh"] = nlohmann::json::parse(Dump(in.mesh, -1));
  report["sentence"] = sentence;
  report["summary"] =
      SummaryJson(*opened, *result, sdf_seconds, in.out.warn_missing_fraction);
  const nlohmann::json& summary = report["summary"];
  report["parameters"] = {
      {"t_min", flags.t_min},
      {"min_region_area", flags.min_region_area},
      {"method", summary["method"]},
      {"cone_angle_degrees", summary["cone_angle_degrees"]},
      {"rays_per_vertex", summary["rays_per_vertex"]},
      {"kappa", in.sdf.kappa},
      {"normals", in.sdf.normals},
      {"max_distance", in.sdf.max_distance},
      {"color_range", {scale->lo, scale->hi}},
      {"bins", flags.bins},
      {"view_size", flags.view_size},
      {"up", flags.up},
  };
  if (result->missing.vertices > 0) {
    report["missing_cause"] = LikelyMissingCause(mesh, result->Causes());
  }
  report["color_range"] = {
      {"low", scale->lo},
      {"high", scale->hi},
      {"source", range->source},
      {"above_label", range->above_label},
      {"above_color", {kOverflowColor.r, kOverflowColor.g, kOverflowColor.b}},
      {"above_area", *above},
  };
  report["thin"] = ThinJson(*thin);
  report["bands"] =
      Bands(mesh, values, samples, flags.t_min, thin->total_area);
  report["histogram"] = {
      {"lo", histogram->lo}, {"hi", histogram->hi}, {"area", histogram->area}};
  report["timing"] = {{"sdf_seconds", sdf_seconds},
                      {"render_seconds", render_seconds}};
  if (absl::Status s =
          WriteText((dir / "report.json").string(), Dump(report, 2) + "\n");
      !s.ok()) {
    return s;
  }
  if (absl::Status s =
          WriteText((dir / "index.html").string(),
                    ReportHtml(report, *views_png, *histogram_png,
                               ViewerData(mesh, values, samples, report)));
      !s.ok()) {
    return s;
  }
  PrintWarnings(report["summary"]["warnings"].get<std::vector<std::string>>());
  std::cout << (in.out.json ? Dump(report, -1) : sentence) << "\n";
  // Written, so that the pictures show where; but a check of a surface
  // mostly without values fails, as a penalty over it does (SPEC v2 §7).
  return CheckMissing(mesh, result->missing, result->Causes(),
                      flags.max_missing_fraction,
                      absl::StrCat("a report (written to '", flags.out, "')"));
}

}  // namespace meshgauge::cli
