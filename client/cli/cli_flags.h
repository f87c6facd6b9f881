// Flags shared by the meshgauge CLI verbs, and their conversion to library
// types. Flags are defined only here and parsed only in main.cc.
#pragma once

#include <string>
#include <vector>

#include "absl/flags/declare.h"
#include "absl/status/statusor.h"
#include "lib/core/components.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"

ABSL_DECLARE_FLAG(std::string, method);
ABSL_DECLARE_FLAG(double, cone_angle);
ABSL_DECLARE_FLAG(int, rays);
ABSL_DECLARE_FLAG(double, kappa);
ABSL_DECLARE_FLAG(int, threads);
ABSL_DECLARE_FLAG(std::vector<std::string>, region_direction);
ABSL_DECLARE_FLAG(bool, reorient);
ABSL_DECLARE_FLAG(bool, drop_degenerate_faces);
ABSL_DECLARE_FLAG(std::string, csv);
ABSL_DECLARE_FLAG(std::string, ply);
ABSL_DECLARE_FLAG(bool, json);
ABSL_DECLARE_FLAG(double, max_distance);
ABSL_DECLARE_FLAG(std::string, normals);
ABSL_DECLARE_FLAG(std::string, out);
ABSL_DECLARE_FLAG(double, size);
ABSL_DECLARE_FLAG(double, radius);
ABSL_DECLARE_FLAG(std::string, weights);
ABSL_DECLARE_FLAG(std::string, vjp);
ABSL_DECLARE_FLAG(std::string, jacobian);
ABSL_DECLARE_FLAG(double, t_min);
ABSL_DECLARE_FLAG(std::string, form);
ABSL_DECLARE_FLAG(double, rho);
ABSL_DECLARE_FLAG(double, max_missing_fraction);
ABSL_DECLARE_FLAG(int, samples);
ABSL_DECLARE_FLAG(uint64_t, seed);
ABSL_DECLARE_FLAG(double, power);
ABSL_DECLARE_FLAG(std::string, grad);
ABSL_DECLARE_FLAG(double, tolerance);
ABSL_DECLARE_FLAG(int, bins);

namespace meshgauge::cli {

// Rewrites argv so that `--cone-angle` style names become absl's
// `--cone_angle`, and repeated `--region-direction A --region-direction B`
// become one comma-separated list. Values are left untouched.
std::vector<std::string> NormalizeArgs(int argc, char** argv);

// SdfParams from --method --cone-angle --rays --kappa --threads
// --max-distance --normals. Errors: InvalidArgument naming the flag.
absl::StatusOr<SdfParams> SdfParamsFromFlags();

// PenaltyParams from --t-min --form --power --rho
// --max-missing-fraction, validated. Errors:
// InvalidArgument naming the flag.
absl::StatusOr<PenaltyParams> PenaltyParamsFromFlags();

// A mesh read from a file with --region-direction, --drop-degenerate-faces
// and --reorient applied.
struct LoadedMesh {
  Mesh mesh;
  std::string format;
  int64_t polygons_triangulated = 0;
  int64_t dropped_faces = 0;
  double signed_volume = 0;
  bool closed = false;
  int64_t reoriented = 0;       // components reversed.
  MeshDiagnostics diagnostics;  // after the fixes.
  std::vector<std::string> warnings;
};

// Reads and validates `path`; inward-oriented closed components, double-
// sided faces and open meshes are reported in `warnings`; the inward
// components are reversed only with --reorient.
absl::StatusOr<LoadedMesh> LoadMeshFromFlags(const std::string& path);

}  // namespace meshgauge::cli
