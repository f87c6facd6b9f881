// meshgauge_grpc_bench: the cost of going through the server.
//
//   meshgauge_grpc_bench [--iterations N] MESH
//
// In one process: an in-process server on a loopback port and the library.
//  1. One optimiser iteration (move every vertex -> SDF values -> VJP with
//     g = 1) through gRPC (UpdatePositions, ComputeSdf stream, ComputeVjp
//     reusing the frozen hits) vs the same work on an SdfEvaluator
//     (UpdatePositions, Compute with hit table, ComputeVjp). Best of N.
//  2. A position update on a live session (BVH refit) vs re-uploading the
//     mesh as a new session and building its BVH. Best of N.
//  3. An upload of the mesh's arrays (MB/s of the wire bytes) beside the
//     local read of its file (read, validate, diagnose). Best of N.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "client/remote/remote_client.h"
#include "lib/core/sensitivity.h"
#include "lib/core/stopwatch.h"
#include "lib/embree/sdf.h"
#include "lib/io/mesh_io.h"
#include "server/server.h"
#include "server/flags_help.h"

ABSL_FLAG(int, iterations, 5, "repetitions of each measurement (best kept)");

namespace meshgauge::bench {
namespace {

double Best(int n, const std::function<void(int)>& body) {
  double best = 1e300;
  for (int i = 0; i < n; ++i) {
    const Stopwatch watch;
    body(i);
    best = std::min(best, watch.Seconds());
  }
  return best;
}

void Check(const absl::Status& s) {
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", std::string(s.message()).c_str());
    std::exit(1);
  }
}

int Run(const std::string& path) {
  auto mesh = ReadMesh(path);
  Check(mesh.status());
  const int n0 = absl::GetFlag(FLAGS_iterations);
  const double read = Best(n0, [&](int) {
    auto file = ReadMeshFile(path);
    Check(file.status());
    Check(RepairFileMesh(std::move(*file), {}).status());
  });
  if (IsClosed(*mesh) && SignedVolume(*mesh) < 0) ReverseFaces(*mesh);
  const int n = absl::GetFlag(FLAGS_iterations);
  const int64_t nv = mesh->num_vertices();
  const std::vector<double> ones(nv, 1.0);
  auto moved = [&](int i) {
    std::vector<Vec3> p = mesh->positions;
    const double s = 1 + 1e-5 * std::sin(1.0 + i);
    for (Vec3& v : p) v *= s;
    return p;
  };

  // In-process.
  auto ev = SdfEvaluator::Create(*mesh);
  Check(ev.status());
  const double local = Best(n, [&](int i) {
    Check((*ev)->UpdatePositions(moved(i)));
    HitTable hits;
    Check((*ev)->Compute({}, {}, &hits).status());
    Check(ComputeVjp(**ev, hits, ones).status());
  });

  // Through gRPC on loopback.
  server::ServerOptions options;
  options.address = "127.0.0.1:0";
  options.metrics_address = "";
  options.drain_notice_seconds = 0;
  options.rebuild_every_updates = 1000000;  // measure refits only.
  server::Metrics metrics;
  server::SteadyClock clock;
  auto srv = server::MeshGaugeServer::Start(options, &metrics, &clock);
  Check(srv.status());
  client::RemoteClient c("127.0.0.1:" + std::to_string((*srv)->port()));
  Check(c.Upload(*mesh, "bench").status());
  int64_t generation = 0;
  const SdfParams params;
  // Build the BVH (lazily) before timing.
  Check(c.UpdatePositions("bench", generation++, 3, mesh->positions).status());
  const double remote = Best(n, [&](int i) {
    Check(c.UpdatePositions("bench", generation++, 3, moved(i)).status());
    Check(c.ComputeSdf("bench", params).status());
    auto vjp = c.ComputeVjp("bench", params, ones);
    Check(vjp.status());
    if (!vjp->facts.reused_hits) std::fprintf(stderr, "VJP traced again!\n");
  });

  // A VJP that reuses the last ray pass vs one that must trace.
  double reused = 1e300, traced = 1e300;
  for (int i = 0; i < n; ++i) {
    Check(c.UpdatePositions("bench", generation++, 3, moved(i)).status());
    Stopwatch watch;
    Check(c.ComputeVjp("bench", params, ones).status());  // traces
    traced = std::min(traced, watch.Seconds());
    watch.Restart();
    Check(c.ComputeVjp("bench", params, ones).status());  // reuses
    reused = std::min(reused, watch.Seconds());
  }

  // Refit vs re-upload + rebuild.
  const double refit = Best(n, [&](int i) {
    Check(c.UpdatePositions("bench", generation++, 3, moved(i)).status());
  });
  const double reupload = Best(n, [&](int i) {
    const std::string id = "re" + std::to_string(i);
    Check(c.Upload(*mesh, id).status());
    Check(c.UpdatePositions(id, 0, 3, mesh->positions).status());  // builds
    Check(c.Delete(id));
  });
  const double upload = Best(n, [&](int i) {
    const std::string id = "up" + std::to_string(i);
    Check(c.Upload(*mesh, id).status());
    Check(c.Delete(id));
  });
  (*srv)->Shutdown();
  // The arrays' wire bytes: float64 coordinates, int32 sizes and indices.
  int64_t indices = 0;
  for (const Face& f : mesh->faces) indices += f.size;
  const double megabytes =
      (24.0 * nv + 4.0 * (mesh->num_faces() + indices)) / 1e6;

  std::printf("%s: %lld vertices, %lld faces, best of %d\n",
              path.substr(path.find_last_of('/') + 1).c_str(),
              static_cast<long long>(nv),
              static_cast<long long>(mesh->num_faces()), n);
  std::printf(
      "  optimiser iteration (update + SDF + VJP): in-process %.3f s, "
      "gRPC %.3f s, ratio %.3f (goal <= 1.15)\n",
      local, remote, remote / local);
  std::printf(
      "  VJP reusing the cached ray pass %.3f s vs tracing anew %.3f s: "
      "%.1fx\n",
      reused, traced, traced / reused);
  std::printf(
      "  position update (refit) %.3f s vs re-upload + rebuild %.3f s: "
      "%.1fx (goal >= 5)\n",
      refit, reupload, reupload / refit);
  std::printf(
      "  upload of the arrays %.3f s (%.1f MB, %.1f MB/s) vs reading the file "
      "locally %.3f s: ratio %.2f\n",
      upload, megabytes, megabytes / upload, read, upload / read);
  return 0;
}

}  // namespace
}  // namespace meshgauge::bench

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage(
      "meshgauge_grpc_bench [--iterations N] MESH");
  // --help lists this file's flags (absl's own finds none: No flags matched).
  meshgauge::ListOwnFlagsInHelp(argc, argv, "bench/grpc_bench.cc");
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() != 2) {
    std::fprintf(stderr, "usage: meshgauge_grpc_bench [--iterations N] MESH\n");
    return 2;
  }
  return meshgauge::bench::Run(args[1]);
}
