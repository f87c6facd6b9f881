#include "bench/ray_test_compare.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <numeric>
#include <vector>

#include "lib/embree/sdf_evaluator.h"

namespace meshgauge::bench {

absl::StatusOr<RayTestComparison> CompareRayTests(const Mesh& mesh,
                                                  const SdfParams& params,
                                                  int threads, int rounds) {
  // [0]: watertight, [1]: fast.
  constexpr RayTest kTests[2] = {RayTest::kWatertight, RayTest::kFast};
  std::unique_ptr<SdfEvaluator> evaluators[2];
  for (int i = 0; i < 2; ++i) {
    auto made = SdfEvaluator::Create(
        mesh, {.bvh_policy = BvhUpdatePolicy::kRebuild, .ray_test = kTests[i]});
    if (!made.ok()) return made.status();
    evaluators[i] = std::move(*made);
  }
  SdfResult results[2];
  double rates[2] = {0, 0};
  for (int round = 0; round < std::max(rounds, 1); ++round) {
    for (int i = 0; i < 2; ++i) {
      auto pass = evaluators[i]->Compute(params, {.threads = threads});
      if (!pass.ok()) return pass.status();
      rates[i] = std::max(rates[i], pass->rays_traced / pass->trace_seconds);
      results[i] = std::move(*pass);
    }
  }
  RayTestComparison c;
  c.rays = results[0].rays_traced;
  c.watertight_rate = rates[0];
  c.fast_rate = rates[1];
  const std::vector<int32_t>& hits0 = results[0].hits;
  const std::vector<int32_t>& hits1 = results[1].hits;
  c.watertight_hits = std::accumulate(hits0.begin(), hits0.end(), int64_t{0});
  c.fast_hits = std::accumulate(hits1.begin(), hits1.end(), int64_t{0});
  const std::vector<double>& a = results[0].values;
  const std::vector<double>& b = results[1].values;
  c.vertices = std::ssize(a);
  for (size_t v = 0; v < a.size(); ++v) {
    if (std::memcmp(&a[v], &b[v], sizeof(double)) == 0) continue;
    ++c.differing;
    if (!std::isnan(a[v]) && !std::isnan(b[v]) && a[v] != 0) {
      c.max_relative_difference =
          std::max(c.max_relative_difference, std::abs(b[v] - a[v]) / a[v]);
    }
  }
  return c;
}

}  // namespace meshgauge::bench
