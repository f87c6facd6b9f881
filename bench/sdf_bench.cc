// meshgauge_bench: ray-pass throughput of meshgauge vs raw Embree.
//
//   meshgauge_bench [--repeat N] [--threads T] MESH...
//
// For each mesh (closed meshes with negative volume are reversed first),
// runs in one process, alternating their order, N times each:
//  * the raw Embree pass (bench/raw_embree_pass.h) and meshgauge's full SDF
//    pass (CONE, defaults): best rate of each and their ratio;
//  * a values-only pass vs a values pass keeping the hit table followed by
//    the VJP (all-ones g): best times and their ratio (goal <= 1.3).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "bench/raw_embree_pass.h"
#include "lib/core/sensitivity.h"
#include "lib/embree/render.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"

ABSL_FLAG(int, repeat, 4, "runs of each pass; the best is reported");
ABSL_FLAG(int, threads, 0, "threads (0 = all cores)");
ABSL_FLAG(uint64_t, permute_seed, 0,
          "also run each mesh with its vertices randomly permuted (faces "
          "relabelled) by this seed, as a remesher or optimiser leaves them; "
          "0: only the file order");

namespace meshgauge::bench {
namespace {

// The mesh with its vertices in a random order (fixed seed), faces
// relabelled: the same surface, scattered in memory.
Mesh Permuted(const Mesh& mesh, uint64_t seed) {
  std::vector<int32_t> to(mesh.num_vertices());
  std::iota(to.begin(), to.end(), 0);
  std::shuffle(to.begin(), to.end(), std::mt19937_64(seed));
  Mesh out = mesh;
  for (size_t i = 0; i < to.size(); ++i)
    out.positions[to[i]] = mesh.positions[i];
  for (Face& f : out.faces) {
    for (int k = 0; k < f.size; ++k) f.v[k] = to[f.v[k]];
  }
  return out;
}

int BenchMesh(const std::string& path, uint64_t permute_seed) {
  auto mesh = ReadMesh(path);
  if (!mesh.ok()) {
    std::fprintf(stderr, "%s\n", std::string(mesh.status().message()).c_str());
    return 1;
  }
  if (IsClosed(*mesh) && SignedVolume(*mesh) < 0) ReverseFaces(*mesh);
  std::string name = path.substr(path.find_last_of('/') + 1);
  if (permute_seed != 0) {
    *mesh = Permuted(*mesh, permute_seed);
    name += " (permuted)";
  }
  SdfParams params;
  params.threads = absl::GetFlag(FLAGS_threads);
  auto evaluator =
      SdfEvaluator::Create(*mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild});
  if (!evaluator.ok()) {
    std::fprintf(stderr, "%s\n",
                 std::string(evaluator.status().message()).c_str());
    return 1;
  }
  auto refit_evaluator =
      SdfEvaluator::Create(*mesh, {.bvh_policy = BvhUpdatePolicy::kRefit});
  double best_refit = 0, best_render = 1e300;
  std::vector<double> values;
  double best_raw = 0, best_sdf = 0, best_values = 1e300;
  double best_with_vjp = 1e300, best_vjp = 1e300;
  int64_t rays = 0;
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    // Alternate the order so neither pass always runs on a warmer machine.
    absl::StatusOr<SdfResult> sdf;
    double values_wall = 0;
    auto values_only = [&] {
      const auto start = std::chrono::steady_clock::now();
      sdf = (*evaluator)->Compute(params);
      values_wall = std::chrono::duration<double>(
                        std::chrono::steady_clock::now() - start)
                        .count();
    };
    if (i % 2 == 1) values_only();
    auto raw = RunRawPass(*mesh, params);
    if (i % 2 == 0) values_only();
    best_values = std::min(best_values, values_wall);
    if (!raw.ok() || !sdf.ok()) {
      std::fprintf(stderr, "pass failed\n");
      return 1;
    }
    const auto t0 = std::chrono::steady_clock::now();
    HitTable hits;
    auto kept = (*evaluator)->Compute(params, {}, &hits);
    const auto t1 = std::chrono::steady_clock::now();
    auto vjp = ComputeVjp(**evaluator, hits,
                          std::vector<double>(mesh->num_vertices(), 1.0), {},
                          params.threads);
    const auto t2 = std::chrono::steady_clock::now();
    if (!kept.ok() || !vjp.ok()) {
      std::fprintf(stderr, "values+vjp failed\n");
      return 1;
    }
    best_with_vjp =
        std::min(best_with_vjp, std::chrono::duration<double>(t2 - t0).count());
    best_vjp =
        std::min(best_vjp, std::chrono::duration<double>(t2 - t1).count());
    best_raw = std::max(best_raw, raw->rays / raw->seconds);
    auto refit_pass = (*refit_evaluator)->Compute(params);
    best_refit = std::max(best_refit,
                          refit_pass->rays_traced / refit_pass->trace_seconds);
    best_sdf = std::max(best_sdf, sdf->rays_traced / sdf->trace_seconds);
    rays = sdf->rays_traced;
    values = sdf->values;
  }
  // One 1000 x 800 view, as `meshgauge report --view-size 1000 800` draws
  // each of its four (BVH build included).
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    const auto start = std::chrono::steady_clock::now();
    auto view =
        RenderViews(*mesh, values, ColorScale{0, 1}, {}, {StandardViews(2)[3]},
                    {.width = 1000, .height = 800});
    if (!view.ok()) {
      std::fprintf(stderr, "render failed\n");
      return 1;
    }
    best_render = std::min(
        best_render,
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count());
  }
  std::printf(
      "%-28s %8lld V %11lld rays  raw %.3e rays/s  sdf %.3e rays/s  "
      "sdf/raw %.3f\n",
      name.c_str(), static_cast<long long>(mesh->num_vertices()),
      static_cast<long long>(rays), best_raw, best_sdf, best_sdf / best_raw);
  std::printf("%-28s refit-policy BVH (sessions) %.3e rays/s, %.3f of raw\n",
              "", best_refit, best_refit / best_raw);
  const double values_only = best_values;
  std::printf(
      "%-28s values %.3f s  values+hits+VJP %.3f s (VJP alone %.3f s)  "
      "ratio %.3f\n",
      "", values_only, best_with_vjp, best_vjp, best_with_vjp / values_only);
  std::printf("%-28s render 1000x800 view %.3f s, %.3f of the values pass\n",
              "", best_render, best_render / values_only);
  return 0;
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) {
    rc |= meshgauge::bench::BenchMesh(args[i], 0);
    if (const uint64_t seed = absl::GetFlag(FLAGS_permute_seed); seed != 0) {
      rc |= meshgauge::bench::BenchMesh(args[i], seed);
    }
  }
  return rc;
}
