// Meshes as the benchmarks use them.
#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "lib/core/mesh.h"

namespace meshgauge::bench {

// Reads `path` (any format lib/io reads); a closed mesh whose faces point
// inwards (horse.ply) is turned outwards, so that the cone looks inside
// (then `*turned`, when given, is true).
absl::StatusOr<Mesh> ReadOutwardMesh(const std::string& path,
                                     bool* turned = nullptr);

// The file name of `path` without its directories (a row's label).
std::string BaseName(const std::string& path);

}  // namespace meshgauge::bench
