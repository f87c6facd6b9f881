// Cost against a hub's valence (issue 50): closed cones and cylinders capped
// with fans of 1,000 to 64,000 rim triangles (MakeFanCone, MakeFanCylinder;
// CAD exports cap cones and cylinders this way). Per mesh, on one thread:
//   pass      ComputeSdf with 16 rays per vertex (best of --repeat);
//   hub fans  the same number of rays traced by RayScene::IntersectFan,
//             16 per vertex within 15 degrees of the direction to the
//             solid's centre, with HubFans tracing the fans (the default);
//   embree    the same rays with Embree tracing the fans (as before issue
//             50; up to --embree_max_rim, it grows with the square).
// and each time's ratio to the previous rim's (4 = linear in valence).
//   meshgauge_valence_bench [--repeat N] [--rims A,B,..] [--embree_max_rim R]
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/numbers.h"
#include "lib/core/shapes.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/ray_scene.h"
#include "lib/embree/sdf.h"
#include "server/flags_help.h"

ABSL_FLAG(int, repeat, 3, "rounds of each measurement; the best is kept");
ABSL_FLAG(std::vector<std::string>, rims,
          std::vector<std::string>({"1000", "4000", "16000", "64000"}),
          "rim vertex counts, comma-separated");
ABSL_FLAG(int, embree_max_rim, 16000,
          "largest rim traced with Embree tracing the fans");

namespace meshgauge {
namespace {

double PassSeconds(const Mesh& mesh) {
  const SdfParams params{.rays = 16};
  double best = 1e30;
  for (int r = 0; r < absl::GetFlag(FLAGS_repeat); ++r) {
    Stopwatch watch;
    auto result = ComputeSdf(mesh, params, {.threads = 1});
    if (!result.ok()) {
      std::fprintf(stderr, "%s\n", result.status().ToString().c_str());
      return -1;
    }
    best = std::min(best, watch.Seconds());
  }
  return best;
}

double TraceSeconds(const Mesh& mesh, FanTracing tracing) {
  const MeshTopology topo = MeshTopology::Build(mesh);
  auto scene = RayScene::Create(mesh, topo, BvhUpdatePolicy::kRebuild,
                                RayTest::kWatertight, tracing);
  if (!scene.ok()) return -1;
  const Vec3 centre(0, 0, 0.4);
  std::mt19937 rng(1);
  std::normal_distribution<double> gauss;
  std::vector<std::vector<Vec3>> dirs(mesh.positions.size());
  for (size_t v = 0; v < dirs.size(); ++v) {
    const Vec3 to = centre - mesh.positions[v];
    const Vec3 axis = to / std::max(Norm(to), 1e-300);
    while (dirs[v].size() < 16) {
      Vec3 d(gauss(rng), gauss(rng), gauss(rng));
      d = d / Norm(d);
      if (Dot(d, axis) >= std::cos(M_PI / 12)) dirs[v].push_back(d);
    }
  }
  std::vector<HitCandidates> out(16);
  std::vector<int32_t> ring;
  double best = 1e30;
  for (int r = 0; r < absl::GetFlag(FLAGS_repeat); ++r) {
    Stopwatch watch;
    for (size_t v = 0; v < dirs.size(); ++v) {
      OneRingPrimitives(topo, static_cast<int64_t>(v), &ring);
      (*scene)->IntersectFan(mesh.positions[v], dirs[v],
                             {1e-6f, 1e-6f, 0, 1e30f}, ring,
                             absl::MakeSpan(out));
    }
    best = std::min(best, watch.Seconds());
  }
  return best;
}

void Row(const char* shape, int rim, const Mesh& mesh, double previous[3]) {
  const double now[3] = {PassSeconds(mesh),
                         TraceSeconds(mesh, FanTracing::kHubFans),
                         rim <= absl::GetFlag(FLAGS_embree_max_rim)
                             ? TraceSeconds(mesh, FanTracing::kEmbree)
                             : -1};
  std::printf("| %s | %d |", shape, rim);
  for (int i = 0; i < 3; ++i) {
    if (now[i] < 0) {
      std::printf(" - |");
    } else if (previous[i] > 0) {
      std::printf(" %.3f s (x%.1f) |", now[i], now[i] / previous[i]);
    } else {
      std::printf(" %.3f s |", now[i]);
    }
    previous[i] = now[i];
  }
  std::printf("\n");
  std::fflush(stdout);
}

}  // namespace
}  // namespace meshgauge

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "cost of hub fans against their valence: meshgauge_valence_bench "
      "[--repeat N] [--rims A,B,..] [--embree_max_rim R]");
  // --help lists this file's flags (absl's own finds none).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/valence_bench.cc");
  absl::ParseCommandLine(argc, argv);
  std::printf(
      "| mesh | rim | pass (16 rays, 1 thread) | rays, hub fans | rays, "
      "Embree |\n|---|---|---|---|---|\n");
  for (const char* shape : {"cone", "cylinder"}) {
    double previous[3] = {-1, -1, -1};
    for (const std::string& text : absl::GetFlag(FLAGS_rims)) {
      int rim = 0;
      if (!absl::SimpleAtoi(text, &rim) || rim < 3) {
        std::fprintf(stderr, "--rims: %s is not a count of 3 or more\n",
                     text.c_str());
        return 2;
      }
      const meshgauge::Mesh mesh = shape[1] == 'o'
                                       ? meshgauge::MakeFanCone(rim)
                                       : meshgauge::MakeFanCylinder(rim);
      meshgauge::Row(shape, rim, mesh, previous);
    }
  }
  return 0;
}
