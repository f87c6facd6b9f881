#include "client/cli/cli_flags.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <map>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "lib/core/stopwatch.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {
namespace {

// A number in an interval, checked while parsing (a usage error, exit 2);
// text that is not a number is left to the option's conversion error.
CLI::Validator Interval(double lo, double hi, bool lo_open, bool hi_open) {
  const std::string range = absl::StrCat(
      lo_open ? "(" : "[", lo, ", ", std::isinf(hi) ? "inf" : absl::StrCat(hi),
      hi_open ? ")" : "]");
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0;
        if (!absl::SimpleAtod(text, &v)) return "";
        const bool inside = std::isfinite(v) && (lo_open ? v > lo : v >= lo) &&
                            (hi_open ? v < hi : v <= hi);
        return inside ? "" : absl::StrCat("Value ", text, " not in ", range);
      },
      "in " + range);
}

constexpr double kInf = std::numeric_limits<double>::infinity();

// penalty, report, grad.
void AddMaxMissingFraction(CLI::App* app, double* max_missing_fraction) {
  app->add_option("--max-missing-fraction", *max_missing_fraction,
                  "fail when faces without values cover more than this "
                  "fraction of the surface, [0, 1]")
      ->check(Interval(0, 1, false, false))
      ->capture_default_str();
}

}  // namespace

CLI::Validator Positive() { return Interval(0, kInf, true, true); }
CLI::Validator NonNegative() { return Interval(0, kInf, false, true); }

void AddThreadsFlag(CLI::App* app, int* threads, const std::string& help) {
  app->add_option("--threads", *threads, help)
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
}

void AddSdfFlags(CLI::App* app, SdfFlags* f) {
  app->add_option("--method", f->method,
                  "cone (Shapira et al.), normal (one ray along the axis: "
                  "physical thickness) or sphere (the inscribed ball "
                  "tangent at the vertex, SPEC v2 §5b)")
      ->check(CLI::IsMember({"cone", "normal", "sphere"}))
      ->capture_default_str();
  app->add_option("--cone-angle", f->cone_angle,
                  "full cone opening angle in degrees, (0, 180)")
      ->check(Interval(0, 180, true, true))
      ->capture_default_str();
  app->add_option("--contact-angle", f->contact_angle,
                  "sphere: half-angle in degrees of the cone around the axis "
                  "in which the ball may touch the surface, (0, 90)")
      ->check(Interval(0, 90, true, true))
      ->capture_default_str();
  app->add_flag("--opposite", f->opposite,
                "also report per vertex the point measured against (SPEC "
                "v2 §5c): CSV columns ox,oy,oz");
  app->add_option("--rays", f->rays,
                  "rays per vertex, 1..4096 (default 100 in 3D, 32 in 2D)")
      ->check(CLI::Range(1, 4096));
  app->add_option("--kappa", f->kappa,
                  "outlier filter: keep |t - median| <= kappa sigma, >= 0")
      ->check(NonNegative())
      ->capture_default_str();
  AddThreadsFlag(app, &f->threads, "worker threads (0: all cores)");
  app->add_option("--max-distance", f->max_distance,
                  "rays longer than this are misses (0: bounding-box "
                  "diagonal)")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--normals", f->normals,
                  "vertex normal weighting: area, or angle (values only)")
      ->check(CLI::IsMember({"area", "angle"}))
      ->capture_default_str();
}

void AddMeshFlags(CLI::App* app, MeshFlags* f) {
  app->add_option("--region-direction", f->region_directions,
                  "cone direction per region, ID=inward|outward; repeat the "
                  "flag or separate with commas")
      ->delimiter(',');
  app->add_flag("--reorient", f->reorient,
                "make each component's faces agree with their neighbours, "
                "then reverse each closed component turned inside out for "
                "its nesting (an outer shell with negative signed volume; a "
                "cavity's wall faces into its cavity)");
  app->add_flag("--drop-degenerate-faces", f->drop_degenerate_faces,
                "remove zero-area faces (and say how many) instead of "
                "rejecting the mesh");
  app->add_option_function<std::vector<std::string>>(
         "--weld",
         [f](const std::vector<std::string>& args) {
           f->weld = true;
           if (args.empty() || args[0].empty()) return;
           if (!absl::SimpleAtod(args[0], &f->weld_tolerance)) {
             throw CLI::ValidationError(
                 "--weld",
                 absl::StrCat("'", args[0],
                              "' is not a tolerance (give it as --weld=TOL, "
                              "or --weld alone after the mesh)"));
           }
         },
         "merge duplicated vertices (unwelded exports) before measuring; "
         "TOL: also vertices closer than TOL times the bounding box's "
         "diagonal (0 to 0.01; default: exact duplicates only); outputs stay "
         "per input vertex")
      ->expected(0, 1);
}

void AddOutputFlags(CLI::App* app, OutputFlags* f, bool files) {
  if (files) {
    app->add_option("--csv", f->csv,
                    "write CSV, a row per vertex (or face with --samples "
                    "faces): vertex,x,y,z,sdf,normalized,hits,kept,status");
    app->add_option("--ply", f->ply,
                    "write binary PLY with the SDF in the quality property "
                    "(per vertex, or per face with --samples faces)");
    app->add_option("--opposite-ply", f->opposite_ply,
                    "write the thickness segments (sample -> opposite point, "
                    "SPEC v2 §5c) as a PLY line set: double x y z, quality "
                    "= the value, sample = the vertex or face index; implies "
                    "--opposite");
  }
  app->add_flag("--json", f->json, "print the summary as one JSON object");
  app->add_option("--progress", f->progress,
                  "progress bar on stderr: auto (on a terminal, after 0.5 s), "
                  "always, never")
      ->check(CLI::IsMember({"auto", "always", "never"}))
      ->capture_default_str();
  app->add_option("--warn-missing-fraction", f->warn_missing_fraction,
                  "warn, per component and with its likely cause, when "
                  "values are missing on more than this fraction of the "
                  "surface, [0, 1]")
      ->check(Interval(0, 1, false, false))
      ->capture_default_str();
}

void AddPenaltyFlags(CLI::App* app, PenaltyFlags* f, bool t_min_required) {
  CLI::Option* t =
      app->add_option("--t-min", f->t_min, "minimum thickness, mesh units, > 0")
          ->check(Positive());
  if (t_min_required) t->required();
  app->add_option("--form", f->form,
                  "one-sided max(0,1-t/t_min)^n, thesis (t/t_min-1)^n, or ks, "
                  "the aggregated constraint (1/rho) ln(mean "
                  "exp(rho(1-t/t_min)))")
      ->check(CLI::IsMember({"one-sided", "thesis", "ks"}))
      ->capture_default_str();
  app->add_option("--power", f->power, "penalty power n >= 1")
      ->check(Interval(1, kInf, false, true))
      ->capture_default_str();
  app->add_option("--rho", f->rho, "KS aggregation rho > 0 (--form ks)")
      ->check(Positive())
      ->capture_default_str();
  AddMaxMissingFraction(app, &f->max_missing_fraction);
  app->add_option("--grad", f->grad,
                  "write dP/dx (dG/dx) as CSV vertex,dx,dy,dz");
}

void AddReportFlags(CLI::App* app, ReportFlags* f) {
  app->add_option("--t-min", f->t_min, "minimum thickness, mesh units, > 0")
      ->check(Positive())
      ->required();
  app->add_option("--out", f->out,
                  "directory for views.png, histogram.png, report.json, "
                  "index.html and colored.ply (created)")
      ->required();
  app->add_option("--min-region-area", f->min_region_area,
                  "thin regions of less area (length in 2D) are specks: "
                  "listed, not outlined")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--view-size", f->view_size, "pixels per view: W H, 64..4096")
      ->expected(2)
      ->check(CLI::Range(64, 4096))
      ->capture_default_str();
  app->add_option("--up", f->up, "the mesh's up axis (names the views)")
      ->check(CLI::IsMember({"y", "z"}))
      ->capture_default_str();
  app->add_option("--bins", f->bins, "histogram bins")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app->add_option("--color-range", f->color_range,
                  "thickness at the ends of the colour map: LO HI, thicker in "
                  "the overflow colour (default: 0 and 2 t_min)")
      ->expected(2)
      ->check(Interval(-kInf, kInf, true, true));
  AddMaxMissingFraction(app, &f->max_missing_fraction);
}

void AddGradFlags(CLI::App* app, GradFlags* f) {
  app->add_option("--weights", f->weights,
                  "per-vertex weights g (one number per line, #V lines; "
                  "default all ones)");
  app->add_option("--vjp", f->vjp, "write g^T J as CSV vertex,dx,dy,dz");
  app->add_option("--jacobian", f->jacobian,
                  "write the sparse Jacobian as CSV row,col,dx,dy,dz");
  AddMaxMissingFraction(app, &f->max_missing_fraction);
}

void AddCalibrateFlags(CLI::App* app, CalibrateFlags* f) {
  app->add_option("--t-min", f->t_min, "minimum thickness, mesh units, > 0")
      ->check(Positive())
      ->required();
  app->add_option("--tolerance", f->tolerance,
                  "relative tolerance for SDF == thickness, >= 0")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--bins", f->bins, "histogram bins, 1..1000")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
}

void AddSamplesFlag(CLI::App* app, SdfFlags* f) {
  app->add_option("--samples", f->samples,
                  "where the values are: vertices, or faces (each face's "
                  "centroid along its own normal, SPEC v2 §5c)")
      ->check(CLI::IsMember({"vertices", "faces"}))
      ->capture_default_str();
}

void AddGradcheckFlags(CLI::App* app, GradcheckFlags* f, SdfFlags* sdf) {
  app->add_option("--probes", f->probes, "vertices probed, >= 1 (default 12)")
      ->check(CLI::Range(1, 1000000));
  // --samples N, the count's name before --probes, still works.
  const CLI::Validator count(
      [](std::string& v) -> std::string {
        int n = 0;
        const char* end = v.data() + v.size();
        const auto [ptr, ec] = std::from_chars(v.data(), end, n);
        return ec == std::errc() && ptr == end && n >= 1 && n <= 1000000
                   ? std::string()
                   : "not a count in [1, 1000000]";
      },
      "COUNT");
  app->add_option_function<std::string>(
         "--samples",
         [f, sdf](const std::string& v) {
           if (v == "vertices" || v == "faces") {
             sdf->samples = v;
           } else {
             std::from_chars(v.data(), v.data() + v.size(), f->counted);
           }
         },
         "vertices or faces (as for sdf), or a count of probed vertices "
         "(the older spelling of --probes)")
      ->check(CLI::IsMember({"vertices", "faces"}) | count);
  app->add_option("--seed", f->seed, "sampling seed")->capture_default_str();
  app->add_option("--fd-tolerance", f->fd_tolerance,
                  "relative error allowed on clean samples, > 0")
      ->check(Positive())
      ->capture_default_str();
}

absl::StatusOr<SdfParams> ToSdfParams(const SdfFlags& f) {
  SdfParams p;
  p.method = f.method == "normal"   ? SdfMethod::kNormalRay
             : f.method == "sphere" ? SdfMethod::kSphere
                                    : SdfMethod::kCone;
  p.contact_angle_degrees = f.contact_angle;
  p.opposite_points = f.opposite;
  p.normal_weighting =
      f.normals == "angle" ? NormalWeighting::kAngle : NormalWeighting::kArea;
  p.cone_angle_degrees = f.cone_angle;
  p.rays = f.rays;
  p.kappa = f.kappa;
  p.max_distance = f.max_distance;
  p.samples = f.samples == "faces" ? SampleSet::kFaces : SampleSet::kVertices;
  if (absl::Status s = ValidateParams(p); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--cone-angle/--kappa/--max-distance: ", s.message()));
  }
  return p;
}

absl::StatusOr<PenaltyParams> ToPenaltyParams(const PenaltyFlags& f) {
  PenaltyParams pp;
  pp.t_min = f.t_min;
  pp.power = f.power;
  pp.rho = f.rho;
  pp.max_missing_fraction = f.max_missing_fraction;
  pp.form = f.form == "ks"       ? PenaltyForm::kKs
            : f.form == "thesis" ? PenaltyForm::kThesis
                                 : PenaltyForm::kOneSided;
  if (absl::Status s = ValidatePenaltyParams(pp); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--t-min/--power/--rho/--max-missing-fraction: ", s.message()));
  }
  return pp;
}

namespace {

absl::Status ApplyRegionDirections(Mesh& mesh,
                                   const std::vector<std::string>& entries) {
  for (const std::string& entry : entries) {
    std::vector<std::string> kv = absl::StrSplit(entry, '=');
    int32_t id = 0;
    if (kv.size() != 2 || !absl::SimpleAtoi(kv[0], &id) ||
        (kv[1] != "inward" && kv[1] != "outward")) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--region-direction expects ID=inward|outward, got '", entry, "'"));
    }
    mesh.region_directions[id] =
        kv[1] == "inward" ? ConeDirection::kInward : ConeDirection::kOutward;
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<LoadedMesh> LoadMesh(const std::string& path,
                                    const MeshFlags& flags, int threads) {
  const Stopwatch watch;
  auto read = ReadMeshFile(path);
  if (!read.ok()) return read.status();
  LoadedMesh loaded;
  loaded.read_seconds = watch.Seconds();
  loaded.format = read->format;
  loaded.polygons_triangulated = read->polygons_triangulated;
  loaded.polygons_fallback = read->polygons_fallback;
  if (absl::Status s =
          ApplyRegionDirections(read->mesh, flags.region_directions);
      !s.ok()) {
    return s;
  }
  auto repaired = RepairFileMesh(
      std::move(*read), {.weld = flags.weld,
                         .weld_tolerance = flags.weld_tolerance,
                         .drop_degenerate_faces = flags.drop_degenerate_faces,
                         .reorient = flags.reorient,
                         .threads = threads});
  if (!repaired.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", repaired.status().message()));
  }
  loaded.mesh = std::move(repaired->mesh);
  loaded.weld = std::move(repaired->weld);
  loaded.dropped_faces = repaired->dropped_faces;
  loaded.reoriented = repaired->reorientation.components_turned_outward;
  loaded.faces_made_consistent = repaired->reorientation.faces_made_consistent;
  loaded.diagnostics = std::move(repaired->diagnostics);
  loaded.warnings = loaded.diagnostics.warnings;
  loaded.signed_volume = repaired->signed_volume;
  loaded.closed = loaded.diagnostics.closed;
  loaded.check_seconds = watch.Seconds() - loaded.read_seconds;
  return loaded;
}

}  // namespace meshgauge::cli
