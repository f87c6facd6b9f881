// Small CSV/text helpers shared by the CLI verbs.
#pragma once

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lib/core/vec3.h"

namespace meshgauge::cli {

// Writes `vertex,dx,dy,dz` rows (17 significant digits).
absl::Status WriteVectorCsv(const std::string& path,
                            const std::vector<Vec3>& v);

// Reads per-sample weights: one finite number per non-empty line, exactly
// nv of them; `samples` names them in errors ("vertices", "faces"). Empty
// path: all ones.
absl::StatusOr<std::vector<double>> ReadWeights(
    const std::string& path, int64_t nv,
    absl::string_view samples = "vertices");

// Largest Euclidean norm of the vectors (0 for none).
double MaxNorm(const std::vector<Vec3>& v);

}  // namespace meshgauge::cli
