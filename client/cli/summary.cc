#include "client/cli/summary.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "lib/core/face_sample.h"
#include "lib/core/integrals.h"
#include "lib/core/missing_diagnosis.h"
#include "lib/core/penalty.h"

namespace meshgauge::cli {

nlohmann::json SummaryJson(const Opened& opened, const SdfResult& result,
                           double seconds, double warn_fraction) {
  const LoadedMesh& loaded = opened.loaded;
  nlohmann::json j;
  j["vertices"] = opened.mesh().num_vertices();
  j["faces"] = opened.mesh().num_faces();
  j["dimension"] = opened.mesh().dimension;
  const SdfMethod method = result.resolved.params.method;
  j["method"] = method == SdfMethod::kCone        ? "cone"
                : method == SdfMethod::kNormalRay ? "normal"
                                                  : "sphere";
  j["samples"] = SampleSetName(result.resolved.params.samples);
  j["cone_angle_degrees"] = result.resolved.params.cone_angle_degrees;
  j["contact_angle_degrees"] = result.resolved.params.contact_angle_degrees;
  j["rays_per_vertex"] = result.resolved.rays;
  j["ok"] = result.CountStatus(VertexStatus::kOk);
  j["no_hit"] = result.CountStatus(VertexStatus::kNoHit);
  j["no_faces"] = result.CountStatus(VertexStatus::kNoFaces);
  j["degenerate_normal"] = result.CountStatus(VertexStatus::kDegenerateNormal);
  const ValueStats stats = SummarizeValues(result.values);
  if (stats.count == 0) {
    for (const char* key : {"sdf_min", "sdf_median", "sdf_max", "sdf_mean"}) {
      j[key] = nullptr;
    }
  } else {
    j["sdf_min"] = stats.min;
    j["sdf_max"] = stats.max;
    j["sdf_median"] = stats.median;
    j["sdf_mean"] = stats.mean;
  }
  const IntegralResult integral = IntegrateSdf(opened.mesh(), result);
  j["integral"] = integral.value;
  j["integral_skipped_faces"] = integral.skipped_faces;
  j["rays"] = result.rays_traced;
  j["seconds"] = seconds;
  j["rays_per_second"] = result.trace_seconds > 0
                             ? result.rays_traced / result.trace_seconds
                             : 0.0;
  j["stage_seconds"] = {{"read", loaded.read_seconds},
                        {"checks", loaded.check_seconds},
                        {"setup", opened.setup_seconds},
                        {"rays", result.trace_seconds}};
  nlohmann::json& memory = j["memory_bytes"];
  if (const auto held = opened.backend->Memory()) {
    memory = {{"mesh", held->mesh},
              {"derived", held->derived},
              {"bvh", held->bvh},
              {"hit_table", held->hit_table}};
  }
  rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  memory["peak_rss"] = int64_t{usage.ru_maxrss} * 1024;
  j["closed"] = loaded.closed;
  j[opened.mesh().dimension == 3 ? "signed_volume" : "signed_area"] =
      loaded.signed_volume;
  j["format"] = loaded.format;
  j["polygons_triangulated"] = loaded.polygons_triangulated;
  j["polygons_fallback"] = loaded.polygons_fallback;
  j["dropped_degenerate_faces"] = loaded.dropped_faces;
  j["components"] = loaded.diagnostics.components;
  j["inward_components"] = loaded.diagnostics.inward_components;
  j["double_sided_faces"] = loaded.diagnostics.double_sided_faces;
  j["boundary_edges"] = loaded.diagnostics.boundary_edges;
  j["reoriented_components"] = loaded.reoriented;
  j["faces_made_consistent"] = loaded.faces_made_consistent;
  j["inconsistent_edges"] = loaded.diagnostics.inconsistent_edges;
  j["world_frame_vertices"] = result.world_frame_vertices;
  j["missing_vertices"] = result.missing.vertices;
  j["missing_faces"] = result.missing.faces;
  j["missing_area_fraction"] = result.missing.area_fraction;
  j["warnings"] = PassWarnings(opened, result, warn_fraction);
  return j;
}

std::vector<std::string> PassWarnings(const Opened& opened,
                                      const SdfResult& result,
                                      double warn_fraction) {
  std::vector<std::string> warnings = opened.loaded.warnings;
  for (std::string& w :
       MissingValueWarnings(opened.mesh(), result, warn_fraction)) {
    warnings.push_back(std::move(w));
  }
  return warnings;
}

namespace {

std::string MemoryLine(const nlohmann::json& m) {
  auto mb = [&m](const char* key) { return m[key].get<double>() / 1e6; };
  if (!m.contains("mesh")) {
    return absl::StrFormat("memory: peak RSS %.1f MB\n", mb("peak_rss"));
  }
  return absl::StrFormat(
      "memory: mesh %.1f MB, derived %.1f MB, BVH %.1f MB, hit table %.1f MB, "
      "peak RSS %.1f MB\n",
      mb("mesh"), mb("derived"), mb("bvh"), mb("hit_table"), mb("peak_rss"));
}

}  // namespace

std::string SummaryText(const nlohmann::json& j) {
  auto num = [](const nlohmann::json& v) {
    return v.is_null() ? std::string("-")
                       : absl::StrFormat("%.6g", v.get<double>());
  };
  std::string s = absl::StrFormat(
      "mesh: %dD, %d vertices, %d faces, %s, %d components, %d polygons "
      "triangulated (%s)\n"
      "method: %s\n"
      "%s: %d ok, %d no hit, %d no faces, %d degenerate normal\n"
      "sdf: min %s  median %s  max %s  mean %s\n"
      "integral of sdf over the surface: %.8g (%d faces skipped, %.2f%% of "
      "the area)\n"
      "frames: %d vertices fell back to the world frame\n"
      "rays: %d in %.3f s (%.3g rays/s in the ray pass)\n"
      "time: read %.3f s, checks %.3f s, setup %.3f s, ray pass %.3f s\n"
      "%s",
      j["dimension"].get<int>(), j["vertices"].get<int64_t>(),
      j["faces"].get<int64_t>(), j["closed"].get<bool>() ? "closed" : "open",
      j["components"].get<int64_t>(), j["polygons_triangulated"].get<int64_t>(),
      j["format"].get<std::string>(),
      j["method"] == "normal" ? std::string("normal ray (physical thickness)")
      : j["method"] == "sphere"
          ? absl::StrFormat("inscribed ball, contact cone %g deg",
                            j["contact_angle_degrees"].get<double>())
          : absl::StrFormat("cone, %g deg, %d rays per vertex",
                            j["cone_angle_degrees"].get<double>(),
                            j["rays_per_vertex"].get<int>()),
      j["samples"].get<std::string>(), j["ok"].get<int64_t>(),
      j["no_hit"].get<int64_t>(), j["no_faces"].get<int64_t>(),
      j["degenerate_normal"].get<int64_t>(), num(j["sdf_min"]),
      num(j["sdf_median"]), num(j["sdf_max"]), num(j["sdf_mean"]),
      j["integral"].get<double>(), j["integral_skipped_faces"].get<int64_t>(),
      100 * j["missing_area_fraction"].get<double>(),
      j["world_frame_vertices"].get<int64_t>(), j["rays"].get<int64_t>(),
      j["seconds"].get<double>(), j["rays_per_second"].get<double>(),
      j["stage_seconds"]["read"].get<double>(),
      j["stage_seconds"]["checks"].get<double>(),
      j["stage_seconds"]["setup"].get<double>(),
      j["stage_seconds"]["rays"].get<double>(), MemoryLine(j["memory_bytes"]));
  for (const auto& w : j["warnings"]) {
    absl::StrAppend(&s, "warning: ", w.get<std::string>(), "\n");
  }
  return s;
}

std::vector<Vec3> SamplePoints(const Mesh& mesh, const SdfResult& result) {
  if (result.resolved.params.samples == SampleSet::kVertices) {
    return mesh.positions;
  }
  std::vector<Vec3> centroids(mesh.num_faces());
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    centroids[f] = FaceCentroid(mesh, f);
  }
  return centroids;
}

InputSamples Unwelded(const Weld& weld, const Mesh& mesh,
                      const SdfResult& result) {
  InputSamples in{.points = {}, .result = result};
  in.points.positions = Unweld(weld, mesh.positions);
  SdfResult& r = in.result;
  r.values = Unweld(weld, r.values);
  r.normalized = Unweld(weld, r.normalized);
  r.status = Unweld(weld, r.status);
  r.hits = Unweld(weld, r.hits);
  r.kept = Unweld(weld, r.kept);
  r.opposite = Unweld(weld, r.opposite);
  return in;
}

absl::Status WriteSdfCsv(const std::string& path, const Mesh& mesh,
                         const SdfResult& result) {
  std::ofstream out(path);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  const bool opposite = !result.opposite.empty();
  out << SampleName(result.resolved.params.samples)
      << ",x,y,z,sdf,normalized,hits,kept,status"
      << (opposite ? ",ox,oy,oz\n" : "\n");
  const std::vector<Vec3> points = SamplePoints(mesh, result);
  for (int64_t i = 0; i < std::ssize(points); ++i) {
    const Vec3& p = points[i];
    const bool ok = result.status[i] == VertexStatus::kOk;
    out << absl::StrFormat("%d,%.17g,%.17g,%.17g,", i, p.x, p.y, p.z);
    if (ok) {
      out << absl::StrFormat("%.17g,%.17g", result.values[i],
                             result.normalized[i]);
    } else {
      out << ",";
    }
    out << absl::StrFormat(",%d,%d,%s", result.hits[i], result.kept[i],
                           VertexStatusName(result.status[i]));
    if (opposite && ok) {
      const Vec3& q = result.opposite[i];
      out << absl::StrFormat(",%.17g,%.17g,%.17g", q.x, q.y, q.z);
    } else if (opposite) {
      out << ",,,";
    }
    out << "\n";
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

}  // namespace meshgauge::cli
