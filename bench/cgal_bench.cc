// meshgauge_cgal_bench: meshgauge vs CGAL's sdf_values vs raw Embree.
//
//   meshgauge_cgal_bench [--rays K] [--cone_angle DEG] [MESH...]
//
// For each mesh (the shared meshes given, then generated icospheres and tori
// from about 10k to 400k vertices), in one process, same cone (default
// CGAL's 120 degrees) and ray count (default CGAL's 25):
//  * CGAL::sdf_values with its post-processing (CGAL's default call) and
//    without it, single-threaded as CGAL runs it, one value per facet;
//  * meshgauge ComputeSdf (BVH build + rays + estimator), one value per
//    vertex, all cores;
//  * a raw Embree rtcIntersect1 pass over meshgauge's rays.
// Prints a Markdown table of seconds, rays/s and ratios.
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/mesh_segmentation.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "bench/bench_mesh.h"
#include "bench/raw_embree_pass.h"
#include "lib/core/shapes.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/sdf.h"
#include "server/flags_help.h"

ABSL_FLAG(int, rays, 25, "rays per cone (CGAL's default is 25)");
ABSL_FLAG(double, cone_angle, 120, "cone angle in degrees (CGAL: 2/3 pi)");
ABSL_FLAG(bool, generated, true, "also run generated spheres and tori");
ABSL_FLAG(int64_t, cgal_max_faces, 300000,
          "skip CGAL above this many faces (it would take many minutes)");

namespace meshgauge::bench {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
SurfaceMesh ToCgal(const Mesh& mesh) {
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> v;
  for (const Vec3& p : mesh.positions)
    v.push_back(sm.add_vertex({p.x, p.y, p.z}));
  for (const Face& f : mesh.faces) sm.add_face(v[f.v[0]], v[f.v[1]], v[f.v[2]]);
  return sm;
}

void Row(const std::string& name, const Mesh& mesh) {
  const int rays = absl::GetFlag(FLAGS_rays);
  const double angle = absl::GetFlag(FLAGS_cone_angle);
  const bool run_cgal = mesh.num_faces() <= absl::GetFlag(FLAGS_cgal_max_faces);
  double cgal_default = NAN, cgal_raw = NAN;
  Stopwatch watch;
  if (run_cgal) {
    SurfaceMesh sm = ToCgal(mesh);
    auto sdf =
        sm.add_property_map<SurfaceMesh::Face_index, double>("f:sdf").first;
    const double cone = angle * std::numbers::pi / 180;
    watch.Restart();
    CGAL::sdf_values(sm, sdf, cone, rays, true);
    cgal_default = watch.Seconds();
    watch.Restart();
    CGAL::sdf_values(sm, sdf, cone, rays, false);
    cgal_raw = watch.Seconds();
  }

  SdfParams params;
  params.cone_angle_degrees = angle;
  params.rays = rays;
  watch.Restart();
  auto one = ComputeSdf(mesh, params, {.threads = 1});
  const double one_thread = watch.Seconds();
  watch.Restart();
  auto ours = ComputeSdf(mesh, params);
  const double meshgauge = watch.Seconds();
  auto raw = RunRawPass(mesh, params, /*threads=*/0);
  if (!ours.ok() || !raw.ok() || !one.ok()) {
    std::printf("| %s | meshgauge failed |\n", name.c_str());
    return;
  }
  const double cgal_rays = static_cast<double>(mesh.num_faces()) * rays;
  const double our_rate = ours->rays_traced / ours->trace_seconds;
  std::printf(
      "| %s | %lld | %lld | %.2f | %.2f | %.3f | %.3f | %.2f | %.0fx | %.0fx | "
      "%.2e | %.2e | %.2f |\n",
      name.c_str(), static_cast<long long>(mesh.num_vertices()),
      static_cast<long long>(mesh.num_faces()), cgal_default, cgal_raw,
      one_thread, meshgauge, one_thread / meshgauge, cgal_default / meshgauge,
      our_rate / (cgal_rays / cgal_raw), cgal_rays / cgal_raw, our_rate,
      our_rate / (raw->rays / raw->seconds));
  std::fflush(stdout);
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  using namespace meshgauge;
  absl::SetProgramUsageMessage(
      "meshgauge_cgal_bench [--rays K] [--cone_angle DEG] [MESH...]");
  // --help lists this file's flags (absl's own finds none: No flags matched).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/cgal_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  std::printf(
      "rays %d, cone %g degrees; CGAL single-threaded (per facet), "
      "meshgauge on all cores (per vertex)\n\n",
      absl::GetFlag(FLAGS_rays), absl::GetFlag(FLAGS_cone_angle));
  std::printf(
      "| mesh | V | F | CGAL default s | CGAL no post-processing s | "
      "meshgauge 1 thread s | meshgauge 2 threads s | speed-up | "
      "CGAL default / meshgauge (time) | meshgauge / CGAL (rays/s) | "
      "CGAL rays/s | meshgauge rays/s | meshgauge / raw Embree |\n");
  std::printf(
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- "
      "| --- |\n");
  for (size_t i = 1; i < args.size(); ++i) {
    auto mesh = bench::ReadOutwardMesh(args[i]);
    if (!mesh.ok() || !ValidateMesh(*mesh).ok()) continue;
    bench::Row(bench::BaseName(args[i]), *mesh);
  }
  if (absl::GetFlag(FLAGS_generated)) {
    for (int f : {32, 64, 100, 200}) {  // 10k, 41k, 100k, 400k vertices.
      bench::Row("icosphere f=" + std::to_string(f), MakeIcosphere(1, f));
    }
    for (int n : {150, 300, 600}) {  // 11k, 45k, 180k vertices.
      bench::Row("torus " + std::to_string(n) + "x" + std::to_string(n / 2),
                 MakeTorus(1, 0.4, n, n / 2));
    }
  }
  return 0;
}
