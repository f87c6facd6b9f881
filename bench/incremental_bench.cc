// The cost of incremental ray passes (docs/numerics.md, "Incremental
// passes") against a full pass, as issue 25 states its goals: per mesh, a
// connected patch of about 1 % and 10 % of the vertices (the vertices
// nearest a centre vertex) moved by 1e-3 of the diagonal, and every vertex
// moved. Each pass keeps its hit table (as a server session does) and
// starts from its evaluator's base pass at the original positions; best of
// --repeat. Each patch runs three times: with the default ray starts
// (kAuto), with every ray started at the surface and with rays always
// started past empty balls (issue 52), and prints how many rays the pass
// retraced in unmoved samples against its moved samples' rays.
//   meshgauge_incremental_bench [--repeat N] [--threads T] MESH...
#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "bench/bench_mesh.h"
#include "lib/core/stopwatch.h"
#include "lib/core/topology.h"
#include "lib/embree/sdf_evaluator.h"
#include "server/flags_help.h"

ABSL_FLAG(int, repeat, 3, "rounds of every pass; the best of each is kept");
ABSL_FLAG(int, threads, 0, "threads (0 = all cores)");

namespace meshgauge {
namespace {

// The `count` vertices nearest vertex `centre`.
std::vector<int32_t> NearestVertices(const Mesh& mesh, int64_t centre,
                                     int64_t count) {
  std::vector<int32_t> order(mesh.num_vertices());
  std::iota(order.begin(), order.end(), 0);
  const Vec3 c = mesh.positions[centre];
  auto dist = [&](int32_t v) {
    const Vec3 d = mesh.positions[v] - c;
    return Dot(d, d);
  };
  std::nth_element(order.begin(), order.begin() + count, order.end(),
                   [&](int32_t a, int32_t b) { return dist(a) < dist(b); });
  order.resize(count);
  std::sort(order.begin(), order.end());
  return order;
}

int Bench(const std::string& name, const Mesh& mesh) {
  const SdfParams params;
  const ComputeControl control{.threads = absl::GetFlag(FLAGS_threads)};
  // The default (kAuto), and the same passes with every ray started at the
  // surface and with rays always started past empty balls (issue 52).
  const RayStartMode modes[] = {RayStartMode::kAuto, RayStartMode::kSurface,
                                RayStartMode::kPastEmptyBall};
  std::vector<std::unique_ptr<SdfEvaluator>> evaluators;
  for (RayStartMode mode : modes) {
    auto created = SdfEvaluator::Create(mesh, {.ray_start = mode});
    if (!created.ok()) {
      std::fprintf(stderr, "%s\n",
                   std::string(created.status().message()).c_str());
      return 1;
    }
    evaluators.push_back(*std::move(created));
  }
  const MeshTopology topology = MeshTopology::Build(mesh);
  const int64_t nv = mesh.num_vertices();
  const Vec3 by = Vec3(1, -1, 1) * (1e-3 * BoundingBoxDiagonal(mesh) / 1.732);
  struct Case {
    std::string label;
    std::vector<int32_t> moved;
  };
  std::vector<Case> cases = {
      {"1 % patch", NearestVertices(mesh, nv / 3, nv / 100)},
      {"10 % patch", NearestVertices(mesh, nv / 3, nv / 10)},
      {"every vertex", NearestVertices(mesh, nv / 3, nv)}};
  // Each evaluator's base pass (the first one's timed: the full pass).
  struct Base {
    SdfResult result;
    HitTable hits;
  };
  std::vector<Base> bases(evaluators.size());
  double full = 1e300;
  for (size_t m = 0; m < evaluators.size(); ++m) {
    const int rounds = m == 0 ? absl::GetFlag(FLAGS_repeat) : 1;
    for (int r = 0; r < rounds; ++r) {
      const Stopwatch watch;
      auto pass = evaluators[m]->Compute(params, control, &bases[m].hits);
      if (m == 0) full = std::min(full, watch.Seconds());
      if (!pass.ok()) return 1;
      bases[m].result = std::move(*pass);
    }
  }
  const SdfResult& base = bases[0].result;
  std::printf("%-24s %8lld V  full pass with hit table %.3f s, %lld rays\n",
              name.c_str(), static_cast<long long>(nv), full,
              static_cast<long long>(base.rays_traced));
  for (const Case& c : cases) {
    // The samples the pass traces in full.
    const std::vector<uint8_t> dirty =
        CornersOfFacesAround(topology, mesh, c.moved);
    const int64_t moved_rays = std::ssize(bases[0].hits.cone) *
                               std::count(dirty.begin(), dirty.end(), 1);
    std::vector<Vec3> to;
    for (int32_t v : c.moved) to.push_back(mesh.positions[v] + by);
    std::vector<Vec3> back;
    for (int32_t v : c.moved) back.push_back(mesh.positions[v]);
    for (auto& e : evaluators) {
      if (!e->UpdatePositions(c.moved, to).ok()) return 1;
    }
    // Best of --repeat per mode, the modes alternating within each round.
    double best[3] = {1e300, 1e300, 1e300};
    int64_t traced = 0, past_ball[3] = {0, 0, 0};
    for (int r = 0; r < absl::GetFlag(FLAGS_repeat); ++r) {
      for (size_t m = 0; m < evaluators.size(); ++m) {
        HitTable hits;
        const Stopwatch watch;
        const PreviousPass previous{&bases[m].result, &bases[m].hits};
        auto pass = evaluators[m]->Compute(params, control, &hits, &previous);
        best[m] = std::min(best[m], watch.Seconds());
        if (!pass.ok()) return 1;
        traced = pass->rays_traced;
        past_ball[m] = pass->samples_past_ball;
      }
    }
    for (auto& e : evaluators) {
      if (!e->UpdatePositions(c.moved, back).ok()) return 1;
    }
    std::printf(
        "%-24s %-13s %7lld moved  %.3f s = %.3f of the full pass, "
        "%.3f of its rays traced; %lld samples past balls\n",
        "", c.label.c_str(), static_cast<long long>(c.moved.size()), best[0],
        best[0] / full, static_cast<double>(traced) / base.rays_traced,
        static_cast<long long>(past_ball[0]));
    std::printf(
        "%-24s %-13s rays started at the surface %.3f s (default %.3f of "
        "it); always past balls %.3f s (%.3f of it, %lld samples)\n",
        "", "", best[1], best[0] / best[1], best[2], best[2] / best[1],
        static_cast<long long>(past_ball[2]));
    std::printf(
        "%-24s %-13s rays retraced in unmoved samples: %.3f times the "
        "moved samples' %lld\n",
        "", "", static_cast<double>(traced - moved_rays) / moved_rays,
        static_cast<long long>(moved_rays));
  }
  std::fflush(stdout);
  return 0;
}

}  // namespace
}  // namespace meshgauge

int main(int argc, char** argv) {
  using namespace meshgauge;
  absl::SetProgramUsageMessage(
      "meshgauge_incremental_bench [--repeat N] [--threads T] MESH...");
  // --help lists this file's flags (absl's own finds none: No flags matched).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/incremental_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) {
    auto mesh = bench::ReadOutwardMesh(args[i]);
    if (!mesh.ok()) {
      std::fprintf(stderr, "%s\n",
                   std::string(mesh.status().message()).c_str());
      rc = 1;
      continue;
    }
    rc |= Bench(bench::BaseName(args[i]), *mesh);
  }
  return rc;
}
