// meshgauge_client_bench: one optimiser iteration (move every vertex, SDF
// values, VJP with g = 1) from the C++ client against a running server; the
// baseline of bench/python_client_bench.py (scripts/bench_clients.sh runs
// both against one server).
//
//   meshgauge_client_bench [--iterations N] [--miss_target T2] TARGET MESH
//
// With --miss_target (another replica of the same session store), the
// session is then first used there: the time of that call is a cache miss
// (record loaded from the store, BVH built).
#include <chrono>
#include <cmath>
#include <cstdio>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "client/remote/remote_client.h"
#include "lib/io/mesh_io.h"

ABSL_FLAG(int, iterations, 5, "iterations (the best is reported)");
ABSL_FLAG(std::string, miss_target, "",
          "another replica sharing the session store: time a cache miss there");
ABSL_FLAG(std::string, dump, "",
          "also write the mesh as OBJ here (the Python bench's input)");

int main(int argc, char** argv) {
  std::vector<char*> args = absl::ParseCommandLine(argc, argv);
  if (args.size() != 3) {
    std::fprintf(stderr, "usage: meshgauge_client_bench TARGET MESH\n");
    return 2;
  }
  auto mesh = meshgauge::ReadMesh(args[2]);
  if (!mesh.ok()) {
    std::fprintf(stderr, "%s\n", std::string(mesh.status().message()).c_str());
    return 1;
  }
  if (const std::string dump = absl::GetFlag(FLAGS_dump); !dump.empty()) {
    if (absl::Status s = meshgauge::WriteObj(dump, *mesh); !s.ok()) return 1;
  }
  meshgauge::client::RemoteClient c(args[1]);
  if (auto up = c.Upload(*mesh, "cpp-bench"); !up.ok()) {
    std::fprintf(stderr, "%s\n", std::string(up.status().message()).c_str());
    return 1;
  }
  const auto params = meshgauge::client::ToWireParams({});
  const std::vector<double> ones(mesh->num_vertices(), 1.0);
  double best = 1e300;
  for (int i = 0; i < absl::GetFlag(FLAGS_iterations); ++i) {
    std::vector<meshgauge::Vec3> p = mesh->positions;
    const double s = 1 + 1e-5 * std::sin(1.0 + i);
    for (auto& v : p) v *= s;
    const auto start = std::chrono::steady_clock::now();
    auto up = c.UpdatePositions("cpp-bench", i, mesh->dimension, p);
    auto sdf = c.ComputeSdf("cpp-bench", params);
    auto vjp = c.ComputeVjp("cpp-bench", params, ones);
    if (!up.ok() || !sdf.ok() || !vjp.ok()) {
      std::fprintf(stderr, "iteration failed\n");
      return 1;
    }
    best = std::min(best, std::chrono::duration<double>(
                              std::chrono::steady_clock::now() - start)
                              .count());
  }
  std::printf("C++ client iteration: %.4f s (best of %d)\n", best,
              absl::GetFlag(FLAGS_iterations));
  if (const std::string t2 = absl::GetFlag(FLAGS_miss_target); !t2.empty()) {
    meshgauge::client::RemoteClient other(t2);
    const auto start = std::chrono::steady_clock::now();
    auto info = other.Get("cpp-bench");
    if (!info.ok()) {
      std::fprintf(stderr, "%s\n", std::string(info.status().message()).c_str());
      return 1;
    }
    std::printf("cache miss on %s (load from the store + BVH build): %.4f s\n",
                t2.c_str(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                              start)
                    .count());
  }
  (void)c.Delete("cpp-bench");
  return 0;
}
