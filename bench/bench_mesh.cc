#include "bench/bench_mesh.h"

#include "lib/io/mesh_io.h"

namespace meshgauge::bench {

absl::StatusOr<Mesh> ReadOutwardMesh(const std::string& path, bool* turned) {
  auto mesh = ReadMesh(path);
  if (!mesh.ok()) return mesh.status();
  const bool inward = IsClosed(*mesh) && SignedVolume(*mesh) < 0;
  if (inward) ReverseFaces(*mesh);
  if (turned != nullptr) *turned = inward;
  return mesh;
}

std::string BaseName(const std::string& path) {
  return path.substr(path.find_last_of('/') + 1);
}

}  // namespace meshgauge::bench
