// The VJP's scatter alone (issue 52): every row of one pass's Jacobian
// added into a VJP's exact sums, in the VJP's visiting order, with weights
// 1.0 to 1.6, three ways:
//   adds  ExactSums::Add three times a term, with the sums of the term 8
//         ahead prefetched (what AddScaledTerms must equal bit for bit;
//         the VJP's scatter until the sixteenth session);
//   avx   ExactSums::AddScaledTerms in AVX lanes (a VJP's, where the CPU
//         has AVX);
//   sse2  the same in the baseline's: x and y in an SSE2 pair, z alone.
// One thread, best of --repeat, rounds interleaved; the three must give the
// same sums. The Jacobian is held whole (about 32 bytes a row entry: 0.9 GB
// on igea at 100 rays).
//   meshgauge_scatter_bench [--rays K] [--repeat N] MESH...
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/types/span.h"
#include "bench/bench_mesh.h"
#include "lib/core/exact_sum.h"
#include "lib/core/row_term.h"
#include "lib/core/sensitivity.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/sdf_evaluator.h"
#include "server/flags_help.h"

ABSL_FLAG(int, rays, 100, "rays per vertex");
ABSL_FLAG(int, repeat, 7, "rounds of each way; the best is kept");

namespace meshgauge {
namespace {

enum Way { kAdds, kAvx, kSse2, kWays };
constexpr const char* kWayNames[kWays] = {"adds", "avx", "sse2"};

// One scatter of every row: the seconds it took, the sums in *out.
double Scatter(Way way, int64_t vertices, absl::Span<const RowTerm> terms,
               absl::Span<const int64_t> offsets,
               absl::Span<const int32_t> order, ExactSums* out) {
  *out = ExactSums(3 * vertices);
  const Stopwatch watch;
  for (const int32_t p : order) {
    const double g = 1.0 + (p % 7) * 0.1;
    const absl::Span<const RowTerm> row =
        terms.subspan(offsets[p], offsets[p + 1] - offsets[p]);
    if (way != kAdds) {
      out->AddScaledTerms(row, g, way == kAvx);
      continue;
    }
    const auto* pairs = static_cast<const char*>(out->storage());
    for (size_t k = 0; k < row.size(); ++k) {
      if (k + 8 < row.size()) {
        const char* ahead = pairs + 48 * int64_t{row[k + 8].vertex};
        __builtin_prefetch(ahead, 1);
        __builtin_prefetch(ahead + 32, 1);
      }
      const RowTerm& t = row[k];
      const int64_t o = 3 * int64_t{t.vertex};
      out->Add(o, t.d.x * g);
      out->Add(o + 1, t.d.y * g);
      out->Add(o + 2, t.d.z * g);
    }
  }
  return watch.Seconds();
}

int Run(const std::string& path) {
  auto mesh = bench::ReadOutwardMesh(path);
  if (!mesh.ok()) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(),
                 std::string(mesh.status().message()).c_str());
    return 1;
  }
  const int64_t vertices = mesh->num_vertices();
  auto ev = SdfEvaluator::Create(*std::move(mesh));
  if (!ev.ok()) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(),
                 std::string(ev.status().message()).c_str());
    return 1;
  }
  SdfParams params;
  params.rays = absl::GetFlag(FLAGS_rays);
  HitTable hits;
  const absl::Status pass = (*ev)->Compute(params, {}, &hits).status();
  absl::StatusOr<SparseJacobian> jac =
      pass.ok() ? ComputeJacobian(**ev, hits) : pass;
  if (!jac.ok()) {
    std::fprintf(stderr, "%s: %s\n", path.c_str(),
                 std::string(jac.status().message()).c_str());
    return 1;
  }
  std::vector<RowTerm> terms(jac->nonzeros());
  for (int64_t k = 0; k < jac->nonzeros(); ++k) {
    terms[k] = {jac->columns[k], jac->values[k]};
  }
  const std::vector<int64_t> offsets = std::move(jac->row_offsets);
  *jac = {};
  const absl::Span<const int32_t> order = (*ev)->vertex_order();
  double best[kWays];
  ExactSums sums[kWays];
  for (double& b : best) b = 1e30;
  for (int r = 0; r < absl::GetFlag(FLAGS_repeat); ++r) {
    for (int w = 0; w < kWays; ++w) {
      best[w] = std::min(best[w], Scatter(static_cast<Way>(w), vertices, terms,
                                          offsets, order, &sums[w]));
    }
  }
  bool same = true;
  for (int w = 1; w < kWays; ++w) {
    same = same && std::memcmp(sums[w].storage(), sums[kAdds].storage(),
                               3 * vertices * 2 * sizeof(double)) == 0;
  }
  std::printf("%-24s %9lld row entries  ", bench::BaseName(path).c_str(),
              static_cast<long long>(terms.size()));
  for (int w = 0; w < kWays; ++w) {
    std::printf("%s %.4f s (%.3f)  ", kWayNames[w], best[w],
                best[w] / best[kAdds]);
  }
  std::printf("%s\n", same ? "same sums" : "SUMS DIFFER");
  return same ? 0 : 1;
}

}  // namespace
}  // namespace meshgauge

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "the VJP's scatter alone (issue 52): meshgauge_scatter_bench [--rays K] "
      "[--repeat N] MESH...");
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/scatter_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  int rc = 0;
  for (size_t i = 1; i < args.size(); ++i) rc |= meshgauge::Run(args[i]);
  return rc;
}
