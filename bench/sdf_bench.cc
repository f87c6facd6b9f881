// meshgauge_bench: ray-pass throughput of meshgauge vs raw Embree.
//
//   meshgauge_bench [--repeat N] [--threads T] MESH...
//
// For each mesh (closed meshes with negative volume are reversed first),
// runs in one process, alternating their order, N times each: the raw Embree pass
// (bench/raw_embree_pass.h) and meshgauge's full SDF pass (CONE, defaults),
// and prints the best rate of each and their ratio.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "bench/raw_embree_pass.h"
#include "lib/mesh_io.h"
#include "lib/sdf.h"

ABSL_FLAG(int, repeat, 4, "runs of each pass; the best is reported");
ABSL_FLAG(int, threads, 0, "threads (0 = all cores)");

namespace meshgauge::bench {
namespace {

int BenchMesh(const std::string& path) {
  auto mesh = ReadMesh(path);
  if (!mesh.ok()) {
    std::fprintf(stderr, "%s\n", std::string(mesh.status().message()).c_str());
    return 1;
  }
  if (IsClosed(*mesh) && SignedVolume(*mesh) < 0) ReverseFaces(*mesh);
  SdfParams params;
  params.threads = absl::GetFlag(FLAGS_threads);
  auto evaluator =
      SdfEvaluator::Create(*mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild});
  if (!evaluator.ok()) {
    std::fprintf(stderr, "%s\n",
                 std::string(evaluator.status().message()).c_str());
    return 1;
  }
  double best_raw = 0, best_sdf = 0;
  int64_t rays = 0;
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    // Alternate the order so neither pass always runs on a warmer machine.
    absl::StatusOr<SdfResult> sdf;
    if (i % 2 == 1) sdf = (*evaluator)->Compute(params);
    auto raw = RunRawPass(*mesh, params);
    if (i % 2 == 0) sdf = (*evaluator)->Compute(params);
    if (!raw.ok() || !sdf.ok()) {
      std::fprintf(stderr, "pass failed\n");
      return 1;
    }
    best_raw = std::max(best_raw, raw->rays / raw->seconds);
    best_sdf = std::max(best_sdf, sdf->rays_traced / sdf->trace_seconds);
    rays = sdf->rays_traced;
  }
  std::printf("%-28s %8lld V %11lld rays  raw %.3e rays/s  sdf %.3e rays/s  "
              "sdf/raw %.3f\n",
              path.substr(path.find_last_of('/') + 1).c_str(),
              static_cast<long long>(mesh->num_vertices()),
              static_cast<long long>(rays), best_raw, best_sdf,
              best_sdf / best_raw);
  return 0;
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) {
    rc |= meshgauge::bench::BenchMesh(args[i]);
  }
  return rc;
}
