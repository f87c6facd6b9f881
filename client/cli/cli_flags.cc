#include "client/cli/cli_flags.h"

#include <map>

#include "absl/flags/flag.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "lib/io/mesh_io.h"

ABSL_FLAG(std::string, method, "cone",
          "SDF method: cone (Shapira et al.) or normal (one ray along the "
          "axis: physical thickness)");
ABSL_FLAG(double, cone_angle, 30,
          "full cone opening angle in degrees, (0,180)");
ABSL_FLAG(int, rays, 0, "rays per vertex, 1..4096 (0: 100 in 3D, 32 in 2D)");
ABSL_FLAG(double, kappa, 1.0,
          "outlier filter: keep |t - median| <= kappa sigma");
ABSL_FLAG(int, threads, 0, "worker threads (0: all cores)");
ABSL_FLAG(std::vector<std::string>, region_direction, {},
          "cone direction per region, ID=inward|outward; repeat the flag or "
          "separate with commas");
ABSL_FLAG(bool, reorient, false,
          "reverse the faces of every closed component whose signed volume "
          "is negative (and only those)");
ABSL_FLAG(bool, drop_degenerate_faces, false,
          "remove zero-area faces (and say how many) instead of rejecting "
          "the mesh");
ABSL_FLAG(std::string, csv, "",
          "write per-vertex CSV: vertex,x,y,z,sdf,normalized,hits,kept,status");
ABSL_FLAG(std::string, ply, "",
          "write binary PLY with the SDF in the per-vertex quality property");
ABSL_FLAG(bool, json, false, "print the summary as one JSON object");
ABSL_FLAG(double, max_distance, 0,
          "rays longer than this are misses (0: bounding-box diagonal)");
ABSL_FLAG(std::string, normals, "area", "vertex normal weighting: area|angle");
ABSL_FLAG(std::string, out, "", "output file (meshgauge shape)");
ABSL_FLAG(double, size, 0.05, "element size (meshgauge shape)");
ABSL_FLAG(double, radius, 1.0, "radius (meshgauge shape)");
ABSL_FLAG(std::string, weights, "",
          "meshgauge grad: per-vertex weights g (one number per line, #V "
          "lines; default all ones)");
ABSL_FLAG(std::string, vjp, "",
          "meshgauge grad: write g^T J as CSV vertex,dx,dy,dz");
ABSL_FLAG(std::string, jacobian, "",
          "meshgauge grad: write the sparse Jacobian as CSV row,col,dx,dy,dz");
ABSL_FLAG(double, t_min, 0, "minimum thickness (penalty, calibrate), > 0");
ABSL_FLAG(
    std::string, form, "one-sided",
    "penalty form: one-sided max(0,1-t/t_min)^n, thesis (t/t_min-1)^n, "
    "or ks, the aggregated constraint (1/rho) ln(mean exp(rho(1-t/t_min)))");
ABSL_FLAG(double, rho, 50, "meshgauge penalty --form ks: aggregation rho > 0");
ABSL_FLAG(double, max_missing_fraction, 0.5,
          "penalty: fail when faces without values cover more than this "
          "fraction of the surface, [0, 1]");
ABSL_FLAG(int, samples, 12, "meshgauge gradcheck: vertices sampled, >= 1");
ABSL_FLAG(uint64_t, seed, 1, "meshgauge gradcheck: sampling seed");
ABSL_FLAG(double, power, 2, "penalty power n >= 1");
ABSL_FLAG(std::string, grad, "",
          "meshgauge penalty: write dP/dx as CSV vertex,dx,dy,dz");
ABSL_FLAG(double, tolerance, 0.01,
          "meshgauge calibrate: relative tolerance for SDF == thickness");
ABSL_FLAG(int, bins, 20, "meshgauge calibrate: histogram bins");

namespace meshgauge::cli {

std::vector<std::string> NormalizeArgs(int argc, char** argv) {
  std::vector<std::string> out;
  std::vector<std::string> regions;
  for (int i = 0; i < argc; ++i) {
    std::string arg = argv[i];
    if (i > 0 && arg.rfind("--", 0) == 0 && arg != "--") {
      const size_t eq = arg.find('=');
      std::string name = arg.substr(2, eq == std::string::npos ? eq : eq - 2);
      for (char& c : name) c = c == '-' ? '_' : c;
      if (name == "region_direction") {
        if (eq != std::string::npos) {
          regions.push_back(arg.substr(eq + 1));
        } else if (i + 1 < argc) {
          regions.push_back(argv[++i]);
        }
        continue;
      }
      arg = "--" + name + (eq == std::string::npos ? "" : arg.substr(eq));
    }
    out.push_back(arg);
  }
  if (!regions.empty()) {
    out.push_back("--region_direction=" + absl::StrJoin(regions, ","));
  }
  return out;
}

absl::StatusOr<SdfParams> SdfParamsFromFlags() {
  SdfParams p;
  const std::string method = absl::GetFlag(FLAGS_method);
  if (method == "cone") {
    p.method = SdfMethod::kCone;
  } else if (method == "normal") {
    p.method = SdfMethod::kNormalRay;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--method must be cone or normal, got '", method, "'"));
  }
  const std::string normals = absl::GetFlag(FLAGS_normals);
  if (normals == "area") {
    p.normal_weighting = NormalWeighting::kArea;
  } else if (normals == "angle") {
    p.normal_weighting = NormalWeighting::kAngle;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--normals must be area or angle, got '", normals, "'"));
  }
  p.cone_angle_degrees = absl::GetFlag(FLAGS_cone_angle);
  p.rays = absl::GetFlag(FLAGS_rays);
  p.kappa = absl::GetFlag(FLAGS_kappa);
  p.threads = absl::GetFlag(FLAGS_threads);
  p.max_distance = absl::GetFlag(FLAGS_max_distance);
  if (absl::GetFlag(FLAGS_rays) < 0 || absl::GetFlag(FLAGS_rays) > 4096) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--rays must be in [1, 4096], got ", absl::GetFlag(FLAGS_rays)));
  }
  if (absl::Status s = ValidateParams(p); !s.ok()) return s;
  return p;
}

absl::StatusOr<PenaltyParams> PenaltyParamsFromFlags() {
  PenaltyParams pp;
  pp.t_min = absl::GetFlag(FLAGS_t_min);
  pp.power = absl::GetFlag(FLAGS_power);
  pp.rho = absl::GetFlag(FLAGS_rho);
  pp.max_missing_fraction = absl::GetFlag(FLAGS_max_missing_fraction);
  const std::string form = absl::GetFlag(FLAGS_form);
  if (form == "one-sided") {
    pp.form = PenaltyForm::kOneSided;
  } else if (form == "thesis") {
    pp.form = PenaltyForm::kThesis;
  } else if (form == "ks") {
    pp.form = PenaltyForm::kKs;
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        "--form must be one-sided, thesis or ks, got '", form, "'"));
  }
  if (absl::Status s = ValidatePenaltyParams(pp); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--t-min/--power/--rho/--max-missing-fraction: ", s.message()));
  }
  return pp;
}

namespace {

absl::Status ApplyRegionDirections(Mesh& mesh) {
  for (const std::string& entry : absl::GetFlag(FLAGS_region_direction)) {
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

absl::StatusOr<LoadedMesh> LoadMeshFromFlags(const std::string& path) {
  auto read = ReadMeshFile(path);
  if (!read.ok()) return read.status();
  LoadedMesh loaded;
  loaded.mesh = std::move(read->mesh);
  loaded.format = read->format;
  loaded.polygons_triangulated = read->polygons_triangulated;
  if (absl::Status s = ApplyRegionDirections(loaded.mesh); !s.ok()) return s;
  if (absl::GetFlag(FLAGS_drop_degenerate_faces)) {
    loaded.dropped_faces = DropDegenerateFaces(loaded.mesh);
    if (loaded.dropped_faces > 0) {
      loaded.warnings.push_back(
          absl::StrCat(loaded.dropped_faces,
                       " zero-area faces dropped (--drop-degenerate-faces)"));
    }
  }
  if (absl::Status s = ValidateMesh(loaded.mesh); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", s.message(),
                     absl::StrContains(s.message(), "zero area")
                         ? " (--drop-degenerate-faces removes them)"
                         : ""));
  }
  if (absl::GetFlag(FLAGS_reorient)) {
    loaded.reoriented = ReorientInwardComponents(loaded.mesh);
    if (loaded.reoriented > 0) {
      loaded.warnings.push_back(absl::StrCat(
          loaded.reoriented,
          " inward-oriented closed components reversed (--reorient)"));
    }
  }
  loaded.diagnostics = DiagnoseMesh(loaded.mesh);
  for (const std::string& w : loaded.diagnostics.warnings) {
    loaded.warnings.push_back(w);
  }
  loaded.closed = IsClosed(loaded.mesh);
  loaded.signed_volume = SignedVolume(loaded.mesh);
  return loaded;
}

}  // namespace meshgauge::cli
