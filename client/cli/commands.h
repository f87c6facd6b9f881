// The meshgauge CLI verbs. Each takes the positional arguments after the
// verb and returns OK or the error to print (exit status 1).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace meshgauge::cli {

// meshgauge sdf MESH [flags]: SDF per vertex, summary on stdout.
absl::Status RunSdf(const std::vector<std::string>& args);

// meshgauge shape circle|sphere|torus|hollow --size H --radius R --out FILE:
// writes an analytic test shape (OBJ; 2D shapes as `l` polylines).
absl::Status RunShape(const std::vector<std::string>& args);

}  // namespace meshgauge::cli
