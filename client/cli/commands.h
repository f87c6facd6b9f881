// The meshgauge CLI verbs. Each takes the positional arguments after the
// verb and returns OK or the error to print (exit status 1).
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace meshgauge::cli {

// meshgauge sdf MESH [flags]: SDF per vertex, summary on stdout.
absl::Status RunSdf(const std::vector<std::string>& args);

// meshgauge grad MESH [--weights FILE] [--vjp FILE] [--jacobian FILE]:
// sensitivities of the SDF (SPEC §6).
absl::Status RunGrad(const std::vector<std::string>& args);

// meshgauge penalty MESH --t-min T [--form one-sided|thesis|ks] [--power n]
// [--rho R] [--grad FILE]: minimum-thickness penalty or aggregated
// constraint and its gradient (SPEC §7).
absl::Status RunPenalty(const std::vector<std::string>& args);

// meshgauge gradcheck MESH [--samples N] [--seed S] [--t-min T]: central
// differences against the analytic derivatives (SPEC §6); exit 1 on FAIL.
absl::Status RunGradcheck(const std::vector<std::string>& args);

// meshgauge calibrate MESH --t-min T [--tolerance R] [--bins N] [--json]:
// SDF vs physical thickness (SPEC §8).
absl::Status RunCalibrate(const std::vector<std::string>& args);

// meshgauge remote upload|list|info|delete|sdf|grad|penalty|update ...:
// the same work through a meshgauge-server (--server host:port).
absl::Status RunRemote(const std::vector<std::string>& args);

// meshgauge shape circle|sphere|torus|hollow --size H --radius R --out FILE:
// writes an analytic test shape (OBJ; 2D shapes as `l` polylines).
absl::Status RunShape(const std::vector<std::string>& args);

}  // namespace meshgauge::cli
