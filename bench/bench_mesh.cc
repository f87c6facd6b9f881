#include "bench/bench_mesh.h"

#include "lib/io/mesh_io.h"

namespace meshgauge::bench {

absl::StatusOr<Mesh> ReadOutwardMesh(const std::string& path) {
  auto mesh = ReadMesh(path);
  if (!mesh.ok()) return mesh.status();
  if (IsClosed(*mesh) && SignedVolume(*mesh) < 0) ReverseFaces(*mesh);
  return mesh;
}

std::string BaseName(const std::string& path) {
  return path.substr(path.find_last_of('/') + 1);
}

}  // namespace meshgauge::bench
