// meshgauge_bench: meshgauge's ray pass and whole run vs raw Embree.
//
//   meshgauge_bench [--repeat N] [--threads T] [--rays R] [--permute_seed S]
//                   [--generated_vertices N] [--cli PATH] MESH...
//   meshgauge_bench --ray_tests_only [--repeat N] [--threads T] MESH...
//   meshgauge_bench --read_only [--repeat N] MESH...
//
// For each mesh (closed meshes with negative volume are reversed first; with
// --permute_seed also with its vertices permuted; with --generated_vertices
// also a generated bumpy torus of about N vertices), N rounds of:
//  * every raw Embree configuration (bench/raw_embree_pass.h): best rate of
//    each, the fastest, and the SPEC ceiling: the fastest ROBUST one with a
//    no-op filter among those that miss no hit (the fewest rays hit over
//    the rounds against the most of any of them);
//  * meshgauge's values pass (CONE, defaults): best rate, ratio to the
//    fastest raw configuration;
//  * the same pass with every ray started at the surface (no empty ball,
//    lib/embree/ray_start.h): best rate, the share of samples that fell
//    back to it in the default pass, and whether both gave the same bits;
//  * the same pass with each traversal forced (FanTraversal: packets of 16,
//    one coherent stream per sample, the cone walk from the surface): best
//    rates against the SPEC ceiling, how the default pass traced (samples
//    walked, fallen back, streamed), how many samples the forced walk took
//    (none where it takes no fan of the pass: over 2^18 primitives, say),
//    and whether all gave the same values, hit and kept counts;
//  * a values-only pass vs a values pass keeping the hit table (best time
//    also shown alone) followed by the VJP (all-ones g): best times and
//    their ratio; then the one-sided penalty with its gradient, t_min at the
//    10th percentile of the values (its VJP's weights nonzero near the
//    thinnest tenth alone): best time, its share of weighted samples, its
//    ratio to the VJP (or why it was not timed);
//  * the inscribed-ball (SPHERE) pass: best time, its ratio to the values
//    pass;
//  * with --cli, the whole `meshgauge sdf FILE --json` run (read, checks,
//    BVH, rays, estimator, summary): best wall time, its ratio to the
//    fastest raw pass over the same rays, its stages, and its peak RSS
//    against the bytes of mesh + BVH + hit table it reports.
// With --ray_tests_only, per mesh only the values pass with Embree's
// watertight test (the default) and with its fast one, over the same rays:
// both rates, hit fractions, and the vertices whose value differs.
// With --read_only, per file only reading it: its bytes into memory (the
// anchor) and ReadMeshFile (bytes, parse, mesh), best time of each.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_cat.h"
#include "bench/bench_mesh.h"
#include "bench/raw_embree_pass.h"
#include "bench/ray_test_compare.h"
#include "lib/core/penalty.h"
#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/render.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"
#include "server/flags_help.h"

ABSL_FLAG(int, repeat, 2, "rounds of every pass; the best of each is kept");
ABSL_FLAG(int, threads, 0, "threads (0 = all cores)");
ABSL_FLAG(int, rays, 0, "rays per vertex (0: the default, 100)");
ABSL_FLAG(double, cone_angle, 30,
          "the cone's full opening angle in degrees (SdfParams' default "
          "30), for every pass and the CLI");
ABSL_FLAG(uint64_t, permute_seed, 0,
          "also run each mesh with its vertices randomly permuted (faces "
          "relabelled) by this seed, as a remesher or optimiser leaves them; "
          "0: only the file order");
ABSL_FLAG(int64_t, generated_vertices, 0,
          "also run a generated bumpy torus of about this many vertices "
          "(0: none)");
ABSL_FLAG(std::string, cli, "",
          "the meshgauge CLI: also time `CLI sdf FILE --json` (empty: skip)");
ABSL_FLAG(bool, ray_tests_only, false,
          "per mesh, only compare the values pass with Embree's watertight "
          "test and with its fast one");
ABSL_FLAG(bool, read_only, false,
          "per file, only reading it: its bytes into memory (the anchor) "
          "against ReadMeshFile, best of --repeat each");
ABSL_FLAG(std::string, mesh_dir, "/tmp",
          "where the permuted and generated meshes are written for the CLI");

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

// A torus (major radius 1) whose tube radius varies around both circles
// (0.2 to 0.4), so thickness varies as on a part; about `vertices` vertices
// in a grid of 2:1 aspect.
Mesh BumpyTorus(int64_t vertices) {
  const int nv = static_cast<int>(std::sqrt(vertices / 2.0));
  const int nu = static_cast<int>(vertices / nv);
  Mesh mesh = MakeTorus(1.0, 0.3, nu, nv);
  for (Vec3& p : mesh.positions) {
    const double u = std::atan2(p.y, p.x);
    const Vec3 centre(std::cos(u), std::sin(u), 0);
    const Vec3 r = p - centre;
    const double v = std::atan2(r.z, Dot(r, centre));
    p = centre + r * (1 + 0.33 * std::sin(5 * u) * std::cos(3 * v));
  }
  return mesh;
}

// True when both hold the same doubles bit for bit (NaNs included).
bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// Best rates of every raw configuration, one round (each configuration
// once) per call, so that drifts of the machine's speed spread over all.
struct RawBest {
  std::vector<RawConfig> configs = RawConfigs();
  std::vector<double> rate = std::vector<double>(configs.size(), 0);
  std::vector<double> build = std::vector<double>(configs.size(), 1e300);
  // The fewest rays with a hit over the rounds, and the rays of a round.
  std::vector<int64_t> hits =
      std::vector<int64_t>(configs.size(), std::numeric_limits<int64_t>::max());
  int64_t rays = 0;

  bool Round(const Mesh& mesh, const SdfParams& params, int threads) {
    for (size_t c = 0; c < configs.size(); ++c) {
      auto raw = RunRawPass(mesh, params, threads, configs[c]);
      if (!raw.ok()) return false;
      rate[c] = std::max(rate[c], raw->rays / raw->seconds);
      build[c] = std::min(build[c], raw->build_seconds);
      hits[c] = std::min(hits[c], raw->hits);
      rays = raw->rays;
    }
    return true;
  }
  // The fastest configuration without a filter (of any kind: plain scenes
  // lose rays through shared edges, and streams lose some too).
  size_t Fastest() const {
    size_t best = 0;
    for (size_t c = 0; c < configs.size(); ++c) {
      if (!configs[c].noop_filter && rate[c] > rate[best]) best = c;
    }
    return best;
  }
  // Prints every configuration, the fastest, those left out of the
  // ceiling and the ceiling (RawConfigs() always has candidates for it).
  void Print(const std::string& name, size_t ceiling) const {
    for (size_t c = 0; c < configs.size(); ++c) {
      std::printf("%-28s raw %-32s %.3e rays/s  build %.3f s  hits %.6f\n",
                  name.c_str(), configs[c].Name().c_str(), rate[c], build[c],
                  static_cast<double>(hits[c]) / rays);
    }
    std::printf("%-28s fastest raw: %s, %.3e rays/s\n", name.c_str(),
                configs[Fastest()].Name().c_str(), rate[Fastest()]);
    for (size_t c = 0; c < configs.size(); ++c) {
      if (configs[c].CeilingCandidate() && hits[c] < hits[ceiling]) {
        std::printf(
            "%-28s %s misses %lld of the %lld hits of the others: not a "
            "ceiling\n",
            name.c_str(), configs[c].Name().c_str(),
            static_cast<long long>(hits[ceiling] - hits[c]),
            static_cast<long long>(hits[ceiling]));
      }
    }
    std::printf("%-28s SPEC ceiling: %s, %.3e rays/s\n", name.c_str(),
                configs[ceiling].Name().c_str(), rate[ceiling]);
  }
};

// `CLI sdf FILE --json` (with --reorient when the benchmark turned the
// file's mesh outward, so that both measure the same mesh), best wall time
// of --repeat runs, against the fastest raw pass over its rays and against
// the library's values pass of this run (`values_seconds`).
void BenchCli(const std::string& name, const std::string& file, bool reorient,
              const SdfParams& params, double raw_rate, double values_seconds) {
  const std::string command = absl::StrCat(
      absl::GetFlag(FLAGS_cli), " sdf '", file, "' --json",
      reorient ? " --reorient" : "", " --threads ",
      absl::GetFlag(FLAGS_threads), " --cone-angle ", params.cone_angle_degrees,
      params.rays > 0 ? absl::StrCat(" --rays ", params.rays) : "");
  double best = 1e300;
  nlohmann::json summary;
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    const Stopwatch watch;
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) return;
    std::string out;
    char buf[4096];
    for (size_t n; (n = fread(buf, 1, sizeof(buf), pipe)) > 0;) {
      out.append(buf, n);
    }
    if (pclose(pipe) != 0) {
      std::fprintf(stderr, "%s failed\n", command.c_str());
      return;
    }
    const double wall = watch.Seconds();
    if (wall < best) {
      best = wall;
      summary = nlohmann::json::parse(out);
    }
  }
  const double raw_seconds = summary["rays"].get<double>() / raw_rate;
  const nlohmann::json& t = summary["stage_seconds"];
  std::printf(
      "%-28s CLI wall %.3f s = %.3f x the values pass (%.3f s), %.3f x the "
      "fastest raw pass (%.3f s); read %.3f s, checks %.3f s, setup %.3f s, "
      "ray pass %.3f s\n",
      name.c_str(), best, best / values_seconds, values_seconds,
      best / raw_seconds, raw_seconds, t["read"].get<double>(),
      t["checks"].get<double>(), t["setup"].get<double>(),
      t["rays"].get<double>());
  const nlohmann::json& m = summary["memory_bytes"];
  auto mb = [&m](const char* key) { return m[key].get<double>() / 1e6; };
  const double counted = mb("mesh") + mb("bvh") + mb("hit_table");
  std::printf(
      "%-28s CLI memory: mesh %.1f MB, derived %.1f MB, BVH %.1f MB, hit "
      "table %.1f MB; peak RSS %.1f MB = %.2f x (mesh + BVH + hit table)\n",
      "", mb("mesh"), mb("derived"), mb("bvh"), mb("hit_table"), mb("peak_rss"),
      mb("peak_rss") / counted);
}

// `file` holds `mesh`, turned outward by the benchmark when `turned`.
int BenchMesh(const std::string& name, const Mesh& mesh,
              const std::string& file, bool turned) {
  SdfParams params;
  params.rays = absl::GetFlag(FLAGS_rays);
  params.cone_angle_degrees = absl::GetFlag(FLAGS_cone_angle);
  const ComputeControl control{.threads = absl::GetFlag(FLAGS_threads)};
  RawBest raw;
  auto evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild});
  if (!evaluator.ok()) {
    std::fprintf(stderr, "%s\n",
                 std::string(evaluator.status().message()).c_str());
    return 1;
  }
  auto refit_evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRefit});
  // The same pass with every ray started at the surface (the Embree pass
  // before issue 52's empty balls): its rate, and that it gives the same
  // bits.
  auto surface_evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild,
                                  .ray_start = RayStartMode::kSurface});
  double best_surface = 0;
  int64_t past_ball = 0, traced_samples = 0;
  bool same_bits = true;
  // The same pass with each traversal (FanTraversal): their rates, and that
  // they give the same bits.
  auto packet_evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild,
                                  .fan_traversal = FanTraversal::kPackets});
  auto stream_evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild,
                                  .fan_traversal = FanTraversal::kStream});
  // The cone walk forced, from the surface (kAuto's choice on small scenes,
  // and larger ones for narrow cones, where its pilot finds little work;
  // elsewhere measured only).
  auto cone_evaluator =
      SdfEvaluator::Create(mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild,
                                  .ray_start = RayStartMode::kSurface,
                                  .fan_traversal = FanTraversal::kCone});
  double best_packets = 0, best_stream = 0, best_cone = 0;
  int64_t streamed = 0, walked = 0, fell_back = 0, forced_walked = 0;
  double pilot = 0;
  bool same_traversal_bits = true;
  double best_refit = 0, best_render = 1e300, best_step = 1e300;
  std::vector<double> values;
  double best_sdf = 0, best_values = 1e300;
  double best_with_vjp = 1e300, best_vjp = 1e300, best_with_hits = 1e300;
  // The penalty's gradient with t_min at the 10th percentile of the values
  // (its weights nonzero near the thinnest tenth only), and that share;
  // why it was not timed, if it was not (a mesh whose values miss).
  double best_penalty = 1e300, penalty_weighted = 0;
  std::string penalty_skipped;
  double best_sphere = 1e300;
  SdfParams sphere = params;
  sphere.method = SdfMethod::kSphere;
  int64_t rays = 0;
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    if (!raw.Round(mesh, params, control.threads)) {
      std::fprintf(stderr, "raw pass failed\n");
      return 1;
    }
    const Stopwatch values_watch;
    auto sdf = (*evaluator)->Compute(params, control);
    best_values = std::min(best_values, values_watch.Seconds());
    if (!sdf.ok()) {
      std::fprintf(stderr, "pass failed\n");
      return 1;
    }
    const Stopwatch with_vjp;
    HitTable hits;
    auto kept = (*evaluator)->Compute(params, control, &hits);
    best_with_hits = std::min(best_with_hits, with_vjp.Seconds());
    const Stopwatch vjp_alone;
    auto vjp = ComputeVjp(**evaluator, hits,
                          std::vector<double>(mesh.num_vertices(), 1.0),
                          control);
    if (!kept.ok() || !vjp.ok()) {
      std::fprintf(stderr, "values+vjp failed\n");
      return 1;
    }
    best_vjp = std::min(best_vjp, vjp_alone.Seconds());
    best_with_vjp = std::min(best_with_vjp, with_vjp.Seconds());
    std::vector<double> finite;
    for (double t : kept->values) {
      if (std::isfinite(t)) finite.push_back(t);
    }
    if (finite.empty()) {
      penalty_skipped = "no value";
    } else {
      std::nth_element(finite.begin(), finite.begin() + finite.size() / 10,
                       finite.end());
      const Stopwatch penalty_watch;
      auto penalty =
          ComputePenalty(**evaluator, *kept,
                         {.t_min = finite[finite.size() / 10]}, &hits, control);
      if (!penalty.ok()) {
        // A mesh whose values miss on much of it, or a 10th percentile of
        // 0: the rest is still timed.
        penalty_skipped = std::string(penalty.status().message());
      } else {
        best_penalty = std::min(best_penalty, penalty_watch.Seconds());
        penalty_weighted =
            static_cast<double>(
                std::ssize(penalty->dp_dt) -
                std::count(penalty->dp_dt.begin(), penalty->dp_dt.end(), 0.0)) /
            std::ssize(penalty->dp_dt);
      }
    }
    const Stopwatch sphere_watch;
    if (!(*evaluator)->Compute(sphere, control).ok()) {
      std::fprintf(stderr, "sphere pass failed\n");
      return 1;
    }
    best_sphere = std::min(best_sphere, sphere_watch.Seconds());
    // An optimiser's step on a session: every vertex moved a little
    // (Embree's BVH refitted, the walk's tree rebuilt if the pass walks, the
    // pass's choice made again), then the pass.
    std::vector<Vec3> moved = mesh.positions;
    for (Vec3& p : moved) p = p * (1 + 1e-6 * (i % 2 + 1));
    const Stopwatch step_watch;
    if (!(*refit_evaluator)->UpdatePositions(moved).ok()) {
      std::fprintf(stderr, "update failed\n");
      return 1;
    }
    auto refit_pass = (*refit_evaluator)->Compute(params, control);
    best_step = std::min(best_step, step_watch.Seconds());
    if (!refit_pass.ok()) {
      std::fprintf(stderr, "refit pass failed\n");
      return 1;
    }
    best_refit = std::max(best_refit,
                          refit_pass->rays_traced / refit_pass->trace_seconds);
    auto surface = (*surface_evaluator)->Compute(params, control);
    if (!surface.ok()) {
      std::fprintf(stderr, "surface-start pass failed\n");
      return 1;
    }
    best_surface =
        std::max(best_surface, surface->rays_traced / surface->trace_seconds);
    // Values, hits and kept of `pass` are those of the default pass.
    auto same_as_default = [&](const SdfResult& pass) {
      return SameBits(sdf->values, pass.values) && pass.hits == sdf->hits &&
             pass.kept == sdf->kept;
    };
    same_bits &= same_as_default(*surface);
    for (const auto& [ev, best] : {std::pair{&packet_evaluator, &best_packets},
                                   std::pair{&stream_evaluator, &best_stream},
                                   std::pair{&cone_evaluator, &best_cone}}) {
      auto pass = (**ev)->Compute(params, control);
      if (!pass.ok()) {
        std::fprintf(stderr, "traversal pass failed\n");
        return 1;
      }
      *best = std::max(*best, pass->rays_traced / pass->trace_seconds);
      same_traversal_bits &= same_as_default(*pass);
      if (ev == &cone_evaluator) forced_walked = pass->samples_cone_walked;
    }
    streamed = sdf->samples_streamed;
    walked = sdf->samples_cone_walked;
    fell_back = sdf->samples_cone_fell_back;
    pilot = sdf->cone_walk_pilot;
    past_ball = sdf->samples_past_ball;
    traced_samples = std::ssize(sdf->values) -
                     sdf->CountStatus(VertexStatus::kNoFaces) -
                     sdf->CountStatus(VertexStatus::kDegenerateNormal);
    best_sdf = std::max(best_sdf, sdf->rays_traced / sdf->trace_seconds);
    rays = sdf->rays_traced;
    values = sdf->values;
  }
  // One 1000 x 800 view, as `meshgauge report --view-size 1000 800` draws
  // each of its four (BVH build included).
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    const Stopwatch watch;
    auto view =
        RenderViews(mesh, values, ColorScale{0, 1}, {}, {StandardViews(2)[3]},
                    {.width = 1000, .height = 800});
    if (!view.ok()) {
      std::fprintf(stderr, "render failed\n");
      return 1;
    }
    best_render = std::min(best_render, watch.Seconds());
  }
  const std::optional<size_t> ceiling_config =
      SpecCeiling(raw.configs, raw.rate, raw.hits);
  if (!ceiling_config) {
    std::fprintf(stderr, "no ROBUST raw configuration with the filter\n");
    return 1;
  }
  raw.Print(name, *ceiling_config);
  const double best_raw = raw.rate[raw.Fastest()];
  std::printf(
      "%-28s %8lld V %11lld rays  fastest raw %.3e rays/s  sdf %.3e rays/s  "
      "sdf/raw %.3f\n",
      name.c_str(), static_cast<long long>(mesh.num_vertices()),
      static_cast<long long>(rays), best_raw, best_sdf, best_sdf / best_raw);
  const double ceiling = raw.rate[*ceiling_config];
  std::printf(
      "%-28s SPEC ceiling (ROBUST, a no-op filter) %.3e rays/s = %.3f of "
      "the fastest raw; sdf %.3f of it\n",
      "", ceiling, ceiling / best_raw, best_sdf / ceiling);
  std::printf(
      "%-28s rays started at the surface (the Embree pass) %.3e rays/s = "
      "%.3f of the ceiling; sdf %.3f of it; fall-back share %.4f (%lld of "
      "%lld samples); values, hits and kept %s\n",
      "", best_surface, best_surface / ceiling, best_sdf / best_surface,
      traced_samples > 0 ? 1 - static_cast<double>(past_ball) / traced_samples
                         : 0.0,
      static_cast<long long>(traced_samples - past_ball),
      static_cast<long long>(traced_samples),
      same_bits ? "bit-identical" : "DIFFER");
  std::printf(
      "%-28s traversal: the pass walked %lld of %lld samples' cones (fell "
      "back %lld; pilot %.2f tests a ray) and streamed %lld; packets %.3e "
      "rays/s = %.3f of the "
      "ceiling, streams %.3e rays/s = %.3f of it, cone walk from the surface "
      "%.3e rays/s = %.3f of it (walked %lld samples; the others streamed); "
      "values, hits and kept %s\n",
      "", static_cast<long long>(walked),
      static_cast<long long>(traced_samples), static_cast<long long>(fell_back),
      pilot, static_cast<long long>(streamed), best_packets,
      best_packets / ceiling, best_stream, best_stream / ceiling, best_cone,
      best_cone / ceiling, static_cast<long long>(forced_walked),
      same_traversal_bits ? "bit-identical" : "DIFFER");
  std::printf(
      "%-28s refit-policy BVH (sessions) %.3e rays/s, %.3f of raw; an "
      "optimiser's step (every vertex moved, then the pass) %.4f s = %.3f of "
      "the values pass\n",
      "", best_refit, best_refit / best_raw, best_step,
      best_step / best_values);
  std::printf(
      "%-28s values %.3f s  values+hits %.3f s  values+hits+VJP %.3f s (VJP "
      "alone %.3f s)  ratio %.3f\n",
      "", best_values, best_with_hits, best_with_vjp, best_vjp,
      best_with_vjp / best_values);
  if (penalty_skipped.empty()) {
    std::printf(
        "%-28s penalty + gradient (one-sided, t_min the 10th percentile: "
        "weights on %.3f of the samples) %.3f s = %.3f of the VJP; values+hits+"
        "penalty %.3f of the values pass\n",
        "", penalty_weighted, best_penalty, best_penalty / best_vjp,
        (best_with_hits + best_penalty) / best_values);
  } else {
    std::printf("%-28s penalty + gradient not timed: %s\n", "",
                penalty_skipped.c_str());
  }
  std::printf("%-28s render 1000x800 view %.3f s, %.3f of the values pass\n",
              "", best_render, best_render / best_values);
  std::printf(
      "%-28s inscribed-ball (SPHERE) pass %.3f s, %.3f of the cone values "
      "pass\n",
      "", best_sphere, best_sphere / best_values);
  if (!absl::GetFlag(FLAGS_cli).empty()) {
    BenchCli(name, file, turned, params, best_raw, best_values);
  }
  std::fflush(stdout);
  return 0;
}

int BenchRayTests(const std::string& name, const Mesh& mesh) {
  SdfParams params;
  params.rays = absl::GetFlag(FLAGS_rays);
  params.cone_angle_degrees = absl::GetFlag(FLAGS_cone_angle);
  auto c = CompareRayTests(mesh, params, absl::GetFlag(FLAGS_threads),
                           absl::GetFlag(FLAGS_repeat));
  if (!c.ok()) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(),
                 std::string(c.status().message()).c_str());
    return 1;
  }
  const double rays = static_cast<double>(c->rays);
  std::printf(
      "%-28s ray test: watertight %.3e rays/s, fast %.3e rays/s (%.3f x); "
      "hit fraction %.7f vs %.7f (hits lost by the fast test: %lld); values "
      "differ at %lld of %lld vertices (%.2e), largest relative difference "
      "%.2e\n",
      name.c_str(), c->watertight_rate, c->fast_rate,
      c->fast_rate / c->watertight_rate, c->watertight_hits / rays,
      c->fast_hits / rays,
      static_cast<long long>(c->watertight_hits - c->fast_hits),
      static_cast<long long>(c->differing), static_cast<long long>(c->vertices),
      static_cast<double>(c->differing) / static_cast<double>(c->vertices),
      c->max_relative_difference);
  std::fflush(stdout);
  return 0;
}

// `mesh` written as a binary PLY under --mesh_dir for the CLI.
std::string Written(const Mesh& mesh, const std::string& name) {
  const std::string path = absl::StrCat(absl::GetFlag(FLAGS_mesh_dir),
                                        "/meshgauge_bench_", name, ".ply");
  if (absl::Status s = WriteQualityPly(
          path, mesh, std::vector<double>(mesh.num_vertices(), 0.0));
      !s.ok()) {
    std::fprintf(stderr, "%s\n", std::string(s.message()).c_str());
  }
  return path;
}

int BenchRead(const std::string& path) {
  double best_bytes = 1e300, best_read = 1e300;
  size_t size = 0;
  std::vector<char> buffer;
  for (int i = 0; i < absl::GetFlag(FLAGS_repeat); ++i) {
    const Stopwatch bytes_watch;
    FILE* f = std::fopen(path.c_str(), "rb");
    if (f == nullptr) {
      std::fprintf(stderr, "%s: cannot open\n", path.c_str());
      return 1;
    }
    buffer.resize(1 << 20);
    size = 0;
    for (size_t n; (n = std::fread(buffer.data(), 1, buffer.size(), f)) > 0;) {
      size += n;
    }
    std::fclose(f);
    best_bytes = std::min(best_bytes, bytes_watch.Seconds());
    const Stopwatch read_watch;
    auto read = ReadMeshFile(path);
    best_read = std::min(best_read, read_watch.Seconds());
    if (!read.ok()) {
      std::fprintf(stderr, "%s\n",
                   std::string(read.status().message()).c_str());
      return 1;
    }
  }
  std::printf(
      "%-28s %zu bytes: bytes alone %.3f s, ReadMeshFile %.3f s = %.1f x\n",
      BaseName(path).c_str(), size, best_bytes, best_read,
      best_read / best_bytes);
  return 0;
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  using namespace meshgauge;
  using namespace meshgauge::bench;
  absl::SetProgramUsageMessage(
      "meshgauge_bench [--repeat N] [--threads T] [--rays R] [--permute_seed "
      "S] [--generated_vertices N] [--cli PATH] MESH...\n  meshgauge_bench "
      "--ray_tests_only [--repeat N] [--threads T] MESH...\n  meshgauge_bench "
      "--read_only [--repeat N] MESH...");
  // --help lists this file's flags (absl's own finds none: No flags matched).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/sdf_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string path = args[i];
    if (absl::GetFlag(FLAGS_read_only)) {
      rc |= BenchRead(path);
      continue;
    }
    bool turned = false;
    auto mesh = ReadOutwardMesh(path, &turned);
    if (!mesh.ok()) {
      std::fprintf(stderr, "%s\n",
                   std::string(mesh.status().message()).c_str());
      rc = 1;
      continue;
    }
    const std::string name = BaseName(path);
    if (absl::GetFlag(FLAGS_ray_tests_only)) {
      rc |= BenchRayTests(name, *mesh);
      continue;
    }
    rc |= BenchMesh(name, *mesh, path, turned);
    if (const uint64_t seed = absl::GetFlag(FLAGS_permute_seed); seed != 0) {
      const Mesh permuted = Permuted(*mesh, seed);
      rc |= BenchMesh(name + " (permuted)", permuted,
                      Written(permuted, "permuted"), /*turned=*/false);
    }
  }
  if (const int64_t n = absl::GetFlag(FLAGS_generated_vertices); n > 0) {
    const Mesh torus = BumpyTorus(n);
    rc |= BenchMesh(absl::StrCat("bumpy torus ", torus.num_vertices(), " V"),
                    torus, Written(torus, "torus"), /*turned=*/false);
  }
  return rc;
}
