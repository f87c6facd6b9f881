// meshgauge_client_bench: one optimiser iteration (move every vertex, SDF
// values, VJP with g = 1) from the C++ client against a running server; the
// baseline of bench/python_client_bench.py (scripts/bench_clients.sh runs
// both against one server).
//
//   meshgauge_client_bench [--iterations N] [--in_process]
//                          [--miss_target T2] TARGET MESH
//
// With --in_process, every remote iteration is followed by the same
// iteration on an SdfEvaluator in this process (UpdatePositions, Compute
// with hit table, ComputeVjp), so that both see the same machine state; the
// best of each and their ratio are printed.
// With --miss_target (another replica of the same session store), the
// session is then first used there: the time of that call is a cache miss
// (record loaded from the store, BVH built).
#include <cmath>
#include <cstdio>
#include <functional>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "client/remote/remote_client.h"
#include "lib/core/sensitivity.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/sdf_evaluator.h"
#include "lib/io/mesh_io.h"
#include "server/flags_help.h"

ABSL_FLAG(int, iterations, 5, "iterations (the best is reported)");
ABSL_FLAG(bool, in_process, false,
          "alternate with the same iteration in this process; print the ratio");
ABSL_FLAG(std::string, miss_target, "",
          "another replica sharing the session store: time a cache miss there");
ABSL_FLAG(std::string, dump, "",
          "also write the mesh as OBJ here (the Python bench's input)");

namespace {

void Check(const absl::Status& s) {
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", std::string(s.message()).c_str());
    std::exit(1);
  }
}

double Seconds(const std::function<void()>& body) {
  const meshgauge::Stopwatch watch;
  body();
  return watch.Seconds();
}

}  // namespace

int main(int argc, char** argv) {
  using meshgauge::Vec3;
  absl::SetProgramUsageMessage(
      "meshgauge_client_bench [--iterations N] [--in_process] [--miss_target T2] TARGET MESH");
  // --help lists this file's flags (absl's own finds none: No flags matched).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/client_iteration_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() != 3) {
    std::fprintf(stderr, "usage: meshgauge_client_bench TARGET MESH\n");
    return 2;
  }
  auto mesh = meshgauge::ReadMesh(args[2]);
  Check(mesh.status());
  if (const std::string dump = absl::GetFlag(FLAGS_dump); !dump.empty()) {
    Check(meshgauge::WriteObj(dump, *mesh));
  }
  meshgauge::client::RemoteClient c(args[1]);
  Check(c.Upload(*mesh, "cpp-bench").status());
  std::unique_ptr<meshgauge::SdfEvaluator> local;
  if (absl::GetFlag(FLAGS_in_process)) {
    auto ev = meshgauge::SdfEvaluator::Create(*mesh);
    Check(ev.status());
    local = std::move(*ev);
  }
  const meshgauge::SdfParams params;
  const std::vector<double> ones(mesh->num_vertices(), 1.0);
  double best = 1e300, best_local = 1e300;
  const int n = absl::GetFlag(FLAGS_iterations);
  for (int i = 0; i < n; ++i) {
    std::vector<Vec3> p = mesh->positions;
    const double s = 1 + 1e-5 * std::sin(1.0 + i);
    for (auto& v : p) v *= s;
    best = std::min(
        best, Seconds([&] {
          Check(c.UpdatePositions("cpp-bench", i, mesh->dimension, p).status());
          Check(c.ComputeSdf("cpp-bench", params).status());
          Check(c.ComputeVjp("cpp-bench", params, ones).status());
        }));
    if (!local) continue;
    best_local =
        std::min(best_local, Seconds([&] {
                   Check(local->UpdatePositions(p));
                   meshgauge::HitTable hits;
                   Check(local->Compute({}, {}, &hits).status());
                   Check(meshgauge::ComputeVjp(*local, hits, ones).status());
                 }));
  }
  std::printf("C++ client iteration: %.4f s (best of %d)\n", best, n);
  if (local) {
    std::printf("in-process iteration: %.4f s (best of %d, interleaved)\n",
                best_local, n);
    std::printf("remote / in-process per iteration: %.3f\n", best / best_local);
  }
  if (const std::string t2 = absl::GetFlag(FLAGS_miss_target); !t2.empty()) {
    meshgauge::client::RemoteClient other(t2);
    const double miss =
        Seconds([&] { Check(other.Get("cpp-bench").status()); });
    std::printf("cache miss on %s (load from the store + BVH build): %.4f s\n",
                t2.c_str(), miss);
  }
  (void)c.Delete("cpp-bench");
  return 0;
}
